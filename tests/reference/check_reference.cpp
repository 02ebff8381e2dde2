// SPDX-License-Identifier: Apache-2.0
#include "check_reference.h"

#include <algorithm>
#include <cmath>

namespace relief::reference {

namespace {

// d/dx of h along one line: at(k) reads the k-th value of the line of n.
template <class At>
double difference(At at, int i, int n, bool periodic)
{
    if (n < 2)
        return 0.0;
    if (periodic)
        return 0.5 * (at((i + 1) % n) - at((i - 1 + n) % n));
    if (i == 0)
        return at(1) - at(0);
    if (i == n - 1)
        return at(n - 1) - at(n - 2);
    return 0.5 * (at(i + 1) - at(i - 1));
}

void gradient(const std::vector<double>& h, int w, int ht, int i, int j, bool periodic_x, bool periodic_y,
              double& gx, double& gy)
{
    gx = difference([&](int k) { return h[std::size_t(j) * w + k]; }, i, w, periodic_x);
    gy = difference([&](int k) { return h[std::size_t(k) * w + i]; }, j, ht, periodic_y);
}

}  // namespace

std::vector<double> height_normals(const std::vector<double>& h, int w, int ht, bool periodic_x,
                                   bool periodic_y, double scale, bool directx)
{
    std::vector<double> n(3 * h.size());
    for (int j = 0; j < ht; ++j)
        for (int i = 0; i < w; ++i) {
            double gx, gy;
            gradient(h, w, ht, i, j, periodic_x, periodic_y, gx, gy);
            gx *= scale;
            gy *= scale;
            const double len = std::sqrt(gx * gx + gy * gy + 1.0);
            const std::size_t t = 3 * (std::size_t(j) * w + i);
            n[t] = -gx / len;
            n[t + 1] = (directx ? 1.0 : -1.0) * (-gy / len);
            n[t + 2] = 1.0 / len;
        }
    return n;
}

RoundTrip round_trip(const std::vector<double>& g, const std::vector<double>& h, int w, int ht,
                     bool periodic_x, bool periodic_y)
{
    std::vector<double> angle;
    double misfit = 0.0, energy = 0.0;
    for (int j = 0; j < ht; ++j)
        for (int i = 0; i < w; ++i) {
            double hx, hy;
            gradient(h, w, ht, i, j, periodic_x, periodic_y, hx, hy);
            const std::size_t t = std::size_t(j) * w + i;
            const double ax = -g[2 * t], ay = -g[2 * t + 1], bx = -hx, by = -hy;
            const double dot = ax * bx + ay * by + 1.0;
            const double na = std::sqrt(ax * ax + ay * ay + 1.0), nb = std::sqrt(bx * bx + by * by + 1.0);
            angle.push_back(std::acos(std::clamp(dot / (na * nb), -1.0, 1.0)) * 180.0 / M_PI);
            misfit += (g[2 * t] - hx) * (g[2 * t] - hx) + (g[2 * t + 1] - hy) * (g[2 * t + 1] - hy);
            energy += g[2 * t] * g[2 * t] + g[2 * t + 1] * g[2 * t + 1];
        }
    RoundTrip r;
    for (double a : angle) {
        r.mean += a / double(angle.size());
        r.max = std::max(r.max, a);
    }
    std::sort(angle.begin(), angle.end());
    r.p95 = angle[std::size_t(std::ceil(0.95 * double(angle.size()))) - 1];
    r.residual_share = energy > 0.0 ? misfit / energy : 0.0;
    return r;
}

double bilinear(const std::vector<double>& h, int w, int ht, double x, double y)
{
    const double tx = x - 0.5, ty = y - 0.5;
    const int i0 = int(std::floor(tx)), j0 = int(std::floor(ty));
    const double fx = tx - i0, fy = ty - j0;
    auto at = [&](int i, int j) {
        return h[std::size_t(std::clamp(j, 0, ht - 1)) * w + std::size_t(std::clamp(i, 0, w - 1))];
    };
    return (1 - fy) * ((1 - fx) * at(i0, j0) + fx * at(i0 + 1, j0)) +
           fy * ((1 - fx) * at(i0, j0 + 1) + fx * at(i0 + 1, j0 + 1));
}

std::vector<double> tessellation_errors(const std::vector<double>& h, int w, int ht, int patch, double scale)
{
    const int px = (w + patch - 1) / patch, py = (ht + patch - 1) / patch;
    std::vector<double> err(std::size_t(px) * py * 64, 0.0);
    for (int p = 0; p < px * py; ++p) {
        const int x0 = (p % px) * patch, y0 = (p / px) * patch;
        const int x1 = std::min(x0 + patch, w), y1 = std::min(y0 + patch, ht);
        for (int L = 1; L <= 64; ++L) {
            const double sx = double(x1 - x0) / L, sy = double(y1 - y0) / L;
            auto z = [&](int a, int b) { return scale * bilinear(h, w, ht, x0 + sx * a, y0 + sy * b); };
            double worst = 0.0;
            for (int j = y0; j < y1; ++j)
                for (int i = x0; i < x1; ++i) {
                    const double u = (i + 0.5 - x0) / sx, v = (j + 0.5 - y0) / sy;
                    const int a = std::min(int(u), L - 1), b = std::min(int(v), L - 1);
                    const double fu = u - a, fv = v - b;
                    // Barycentric weights of the quad's two triangles.
                    double s;
                    if ((2 * a < L) == (2 * b < L))
                        s = fu >= fv ? (1 - fu) * z(a, b) + (fu - fv) * z(a + 1, b) + fv * z(a + 1, b + 1)
                                     : (1 - fv) * z(a, b) + (fv - fu) * z(a, b + 1) + fu * z(a + 1, b + 1);
                    else
                        s = fu + fv <= 1 ? (1 - fu - fv) * z(a, b) + fu * z(a + 1, b) + fv * z(a, b + 1)
                                         : (fu + fv - 1) * z(a + 1, b + 1) + (1 - fv) * z(a + 1, b) +
                                               (1 - fu) * z(a, b + 1);
                    worst = std::max(worst, std::abs(s - scale * h[std::size_t(j) * w + i]));
                }
            bool flat = true;
            for (int j = y0; j < y1; ++j)
                for (int i = x0; i < x1; ++i)
                    flat &= h[std::size_t(j) * w + i] == h[std::size_t(y0) * w + x0];
            err[std::size_t(p) * 64 + std::size_t(L - 1)] = L == 1 && flat ? 0.0 : worst;
        }
    }
    return err;
}

}  // namespace relief::reference
