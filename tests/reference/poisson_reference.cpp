// SPDX-License-Identifier: Apache-2.0
#include "poisson_reference.h"
#include "zero_mean.h"

#include <algorithm>
#include <cmath>
#include <complex>

namespace relief::reference {

namespace {

using cd = std::complex<double>;

// In-place DFT of every row (axis 0) or column (axis 1) of a w x h grid;
// sign -1 forward, +1 inverse (unnormalised).
void dft_axis(std::vector<cd>& a, int w, int h, int axis, int sign)
{
    const int n = axis == 0 ? w : h, lines = axis == 0 ? h : w;
    std::vector<cd> line(n), out(n);
    for (int l = 0; l < lines; ++l) {
        for (int i = 0; i < n; ++i)
            line[i] = axis == 0 ? a[std::size_t(l) * w + i] : a[std::size_t(i) * w + l];
        for (int k = 0; k < n; ++k) {
            cd s = 0;
            for (int i = 0; i < n; ++i)
                s += line[i] * std::polar(1.0, sign * 2.0 * M_PI * double(k) * i / n);
            out[k] = s;
        }
        for (int i = 0; i < n; ++i)
            (axis == 0 ? a[std::size_t(l) * w + i] : a[std::size_t(i) * w + l]) = out[i];
    }
}

double signed_omega(int k, int n)
{
    const int s = k < (n + 1) / 2 ? k : k - n;
    return 2.0 * M_PI * s / n;
}

std::vector<double> periodic_fc(const std::vector<double>& gx, const std::vector<double>& gy, int w, int h,
                                double sigma)
{
    std::vector<cd> X(gx.begin(), gx.end()), Y(gy.begin(), gy.end());
    for (auto* a : {&X, &Y}) {
        dft_axis(*a, w, h, 0, -1);
        dft_axis(*a, w, h, 1, -1);
    }
    std::vector<cd> H(X.size());
    for (int ky = 0; ky < h; ++ky)
        for (int kx = 0; kx < w; ++kx) {
            const std::size_t i = std::size_t(ky) * w + kx;
            const bool nyquist = (w > 1 && 2 * kx == w) || (h > 1 && 2 * ky == h);
            const double wx = signed_omega(kx, w), wy = signed_omega(ky, h);
            const double w2 = wx * wx + wy * wy;
            if (nyquist || w2 == 0.0)
                continue;
            const double gain = sigma > 0 ? 1.0 - std::exp(-0.5 * w2 * sigma * sigma) : 1.0;
            H[i] = cd(0, -1) * (wx * X[i] + wy * Y[i]) / w2 * gain;
        }
    dft_axis(H, w, h, 0, +1);
    dft_axis(H, w, h, 1, +1);
    std::vector<double> out(H.size());
    for (std::size_t i = 0; i < H.size(); ++i)
        out[i] = H[i].real() / (double(w) * h);
    return out;
}

}  // namespace

std::vector<double> poisson(const std::vector<double>& g, int w, int h, const PoissonSettings& s)
{
    // Even extension of the height across a free axis: gx is odd across
    // the vertical edges and even across the horizontal ones; gy the other
    // way round. An axis of one texel stays one texel (nothing to integrate
    // along it).
    const int W = s.periodic_x || w == 1 ? w : 2 * w, H = s.periodic_y || h == 1 ? h : 2 * h;
    std::vector<double> gx(std::size_t(W) * H), gy(gx.size());
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const bool fx = x >= w, fy = y >= h;
            const int sx = fx ? W - 1 - x : x, sy = fy ? H - 1 - y : y;
            const std::size_t src = std::size_t(sy) * w + sx, dst = std::size_t(y) * W + x;
            gx[dst] = (fx ? -1.0 : 1.0) * g[2 * src];
            gy[dst] = (fy ? -1.0 : 1.0) * g[2 * src + 1];
        }
    const std::vector<double> ext = periodic_fc(gx, gy, W, H, s.highpass_sigma);
    std::vector<double> out(std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            out[std::size_t(y) * w + x] = ext[std::size_t(y) * W + x];
    subtract_mean(out);
    return out;
}

namespace {

// Weighted discrete least squares: edges to the right and lower neighbours
// (wrapping along a periodic axis), edge weight c_e = max(min(w_p, w_q), eps) (all 1
// when `unit`), target mean(sg) over the edge plus delta(q) - delta(p);
// plain CG in double to a relative residual of 1e-12. Zero mean.
std::vector<double> discrete_ls(const std::vector<double>& sg, int w, int h, const std::vector<double>& wt,
                                const std::vector<double>& delta, bool periodic_x, bool periodic_y,
                                double eps, bool unit)
{
    struct Edge {
        std::size_t p, q;
        double c, t;
    };
    std::vector<Edge> edges;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t p = std::size_t(y) * w + x;
            for (int axis = 0; axis < 2; ++axis) {
                int nx = x + (axis == 0), ny = y + (axis == 1);
                if (nx == w || ny == h) {
                    if (!(axis == 0 ? periodic_x : periodic_y))
                        continue;
                    nx %= w;
                    ny %= h;
                }
                if (nx == x && ny == y)
                    continue;  // a one-texel axis has no edges
                const std::size_t q = std::size_t(ny) * w + nx;
                const double c = unit ? 1.0 : std::max(std::min(wt[p], wt[q]), eps);
                const double t =
                    0.5 * (sg[2 * p + axis] + sg[2 * q + axis]) + (unit ? 0.0 : delta[q] - delta[p]);
                edges.push_back({p, q, c, t});
            }
        }
    const std::size_t n = std::size_t(w) * h;
    auto apply = [&](const std::vector<double>& v) {
        std::vector<double> out(n, 0.0);
        for (const Edge& e : edges) {
            const double d = e.c * (v[e.p] - v[e.q]);
            out[e.p] += d;
            out[e.q] -= d;
        }
        return out;
    };
    std::vector<double> b(n, 0.0), x(n, 0.0);
    for (const Edge& e : edges) {
        b[e.q] += e.c * e.t;
        b[e.p] -= e.c * e.t;
    }
    auto dot = [&](const std::vector<double>& a, const std::vector<double>& c) {
        double s = 0;
        for (std::size_t i = 0; i < n; ++i)
            s += a[i] * c[i];
        return s;
    };
    std::vector<double> r = b, d = b;
    double rr = dot(r, r);
    const double stop = 1e-24 * std::max(rr, 1e-300);
    for (std::size_t it = 0; it < 20 * n + 100 && rr > stop; ++it) {
        auto q = apply(d);
        const double dq = dot(d, q);
        if (!(dq > 0))
            break;
        const double alpha = rr / dq;
        for (std::size_t i = 0; i < n; ++i) {
            x[i] += alpha * d[i];
            r[i] -= alpha * q[i];
        }
        const double rr_next = dot(r, r);
        for (std::size_t i = 0; i < n; ++i)
            d[i] = r[i] + rr_next / rr * d[i];
        rr = rr_next;
    }
    subtract_mean(x);
    return x;
}

}  // namespace

std::vector<double> poisson_weighted(const std::vector<double>& g, int w, int h,
                                     const std::vector<double>& wt, bool periodic_x, bool periodic_y,
                                     double eps)
{
    const std::size_t n = std::size_t(w) * h;
    std::vector<double> sg(2 * n);
    for (std::size_t i = 0; i < n; ++i) {
        const double s = wt[i] / std::max(wt[i], eps);
        sg[2 * i] = s * g[2 * i];
        sg[2 * i + 1] = s * g[2 * i + 1];
    }
    PoissonSettings settings;
    settings.periodic_x = periodic_x;
    settings.periodic_y = periodic_y;
    const std::vector<double> spectral = poisson(sg, w, h, settings);
    const std::vector<double> discrete = discrete_ls(sg, w, h, wt, {}, periodic_x, periodic_y, eps, true);
    std::vector<double> delta(n);
    for (std::size_t i = 0; i < n; ++i)
        delta[i] = spectral[i] - discrete[i];
    return discrete_ls(sg, w, h, wt, delta, periodic_x, periodic_y, eps, false);
}

}  // namespace relief::reference
