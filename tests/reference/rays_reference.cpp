// SPDX-License-Identifier: Apache-2.0
#include "rays_reference.h"
#include "zero_mean.h"

#include <algorithm>
#include <cmath>

namespace relief::reference {

namespace {

// Distances t in (0, radius) where the ray from the origin's centre crosses
// a texel edge (lines x = k + 0.5 or y = k + 0.5), plus 0 and radius.
std::vector<double> crossings(double d, double radius, std::vector<double> t)
{
    if (std::abs(d) > 1e-12)
        for (int k = 0;; ++k) {
            double tk = (k + 0.5) / std::abs(d);
            if (tk >= radius)
                break;
            t.push_back(tk);
        }
    return t;
}

}  // namespace

void rational_step(int j, const RaySettings& s, int& best_a, int& best_b)
{
    const int limit = std::max(2, (s.rays + 3) / 4);
    const double target = 2.0 * M_PI * (j + s.phase) / s.rays;
    double best = 1e300, best_len = 1e300;
    for (int b = -limit; b <= limit; ++b)
        for (int a = -limit; a <= limit; ++a) {
            int g = std::abs(a), r = std::abs(b);
            while (r) {
                int t = g % r;
                g = r;
                r = t;
            }
            if (g != 1)
                continue;
            double diff = std::fmod(std::abs(std::atan2(double(b), double(a)) - target), 2.0 * M_PI);
            double err = std::min(diff, 2.0 * M_PI - diff);
            double len = std::hypot(double(a), double(b));
            if (err < best - 1e-12 || (err < best + 1e-12 && len < best_len)) {
                best = err;
                best_len = len;
                best_a = a;
                best_b = b;
            }
        }
}

std::vector<double> rays(const std::vector<double>& g, int w, int h, const RaySettings& s)
{
    std::vector<double> out(std::size_t(w) * h, 0.0);
    // Angular weights: half the angle between each direction's neighbours.
    std::vector<double> theta(s.rays), dir_weight(s.rays, 1.0);
    for (int j = 0; j < s.rays; ++j) {
        int a = 1, b = 0;
        if (s.rational)
            rational_step(j, s, a, b);
        theta[j] = s.rational ? std::atan2(double(b), double(a)) : 2.0 * M_PI * (j + s.phase) / s.rays;
        theta[j] = std::fmod(theta[j] + 4.0 * M_PI, 2.0 * M_PI);
    }
    if (s.rays > 1)
        for (int j = 0; j < s.rays; ++j) {
            // Neighbours by angle (ties: by index, as a stable sort would).
            double before = -1e9, after = 1e9;
            for (int k = 0; k < s.rays; ++k) {
                if (k == j)
                    continue;
                auto rel = [&](bool forward) {
                    double d = theta[k] - theta[j];
                    if (d == 0.0)
                        return (k > j) == forward ? 0.0 : (forward ? 2 * M_PI : -2 * M_PI);
                    if (forward)
                        return d > 0 ? d : d + 2 * M_PI;
                    return d < 0 ? d : d - 2 * M_PI;
                };
                after = std::min(after, rel(true));
                before = std::max(before, rel(false));
            }
            dir_weight[j] = 0.5 * (after - before) * s.rays / (2.0 * M_PI);
        }
    for (int py = 0; py < h; ++py)
        for (int px = 0; px < w; ++px) {
            double sum_a = 0.0, sum_w = 0.0;
            for (int j = 0; j < s.rays; ++j) {
                double dx, dy;
                std::vector<double> t{0.0, s.radius};
                if (s.rational) {
                    int a = 1, b = 0;
                    rational_step(j, s, a, b);
                    const double len = std::hypot(double(a), double(b));
                    dx = a / len;
                    dy = b / len;
                    for (int m = 1; m * len < s.radius; ++m)
                        t.push_back(m * len);  // the split at every period boundary
                } else {
                    const double angle = 2.0 * M_PI * (j + s.phase) / s.rays;
                    dx = std::cos(angle);
                    dy = std::sin(angle);
                }
                t = crossings(dx, s.radius, crossings(dy, s.radius, t));
                std::sort(t.begin(), t.end());
                double height = 0.0;
                bool origin = true;
                for (std::size_t i = 0; i + 1 < t.size(); ++i) {
                    const double t0 = t[i], t1 = t[i + 1];
                    if (t1 - t0 <= 1e-9)
                        continue;  // corner crossing: no extent
                    const double tm = 0.5 * (t0 + t1);
                    int qx = px + int(std::lround(dx * tm));
                    int qy = py + int(std::lround(dy * tm));
                    if (s.periodic) {
                        qx = ((qx % w) + w) % w;
                        qy = ((qy % h) + h) % h;
                    } else if (qx < 0 || qx >= w || qy < 0 || qy >= h) {
                        break;
                    }
                    const std::size_t q = std::size_t(qy) * w + qx;
                    const double dh = (g[2 * q] * dx + g[2 * q + 1] * dy) * (t1 - t0);
                    if (!origin) {  // the origin texel is not part of its own mean
                        const double weight = (t1 - t0) * tm * dir_weight[j];
                        sum_a += weight * (height + 0.5 * dh);
                        sum_w += weight;
                    }
                    origin = false;
                    height += dh;
                }
            }
            out[std::size_t(py) * w + px] = sum_w > 0.0 ? -sum_a / sum_w : 0.0;
        }
    subtract_mean(out);
    return out;
}

}  // namespace relief::reference
