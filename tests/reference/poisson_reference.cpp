#include "poisson_reference.h"

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

std::vector<double> periodic_fc(const std::vector<double>& gx, const std::vector<double>& gy,
                                int w, int h, double sigma)
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

} // namespace

std::vector<double> poisson(const std::vector<double>& g, int w, int h, const PoissonSettings& s)
{
    std::vector<double> out;
    if (s.periodic) {
        std::vector<double> gx(std::size_t(w) * h), gy(gx.size());
        for (std::size_t i = 0; i < gx.size(); ++i) {
            gx[i] = g[2 * i];
            gy[i] = g[2 * i + 1];
        }
        out = periodic_fc(gx, gy, w, h, s.highpass_sigma);
    } else {
        // Even extension of the height: gx is odd across the vertical edges
        // and even across the horizontal ones; gy the other way round.
        const int W = 2 * w, H = 2 * h;
        std::vector<double> gx(std::size_t(W) * H), gy(gx.size());
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const bool fx = x >= w, fy = y >= h;
                const int sx = fx ? W - 1 - x : x, sy = fy ? H - 1 - y : y;
                const std::size_t src = std::size_t(sy) * w + sx, dst = std::size_t(y) * W + x;
                gx[dst] = (fx ? -1.0 : 1.0) * g[2 * src];
                gy[dst] = (fy ? -1.0 : 1.0) * g[2 * src + 1];
            }
        // Dimensions of size 1 stay size 1 (nothing to integrate along them).
        std::vector<double> ext = periodic_fc(gx, gy, W, H, s.highpass_sigma);
        out.resize(std::size_t(w) * h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                out[std::size_t(y) * w + x] = ext[std::size_t(y) * W + x];
    }
    double mean = 0;
    for (double v : out)
        mean += v;
    mean /= double(out.size());
    for (double& v : out)
        v -= mean;
    return out;
}

namespace {

// The spectral derivative along one axis of length n as an n x n matrix
// (row-major): the derivative of the Frankot–Chellappa basis, Nyquist term
// dropped; for a free axis, that of the even extension, cropped. `project`
// gives instead the projection that only drops the Nyquist term (the other
// axis's share of a dropped 2-D frequency).
std::vector<double> axis_operator(int n, bool periodic, bool project)
{
    std::vector<double> m(std::size_t(n) * n, 0.0);
    const int N = periodic ? n : 2 * n;
    for (int j = 0; j < n; ++j) {
        std::vector<cd> line(N, 0.0);
        line[j] = 1.0;
        if (!periodic)
            line[N - 1 - j] = 1.0;
        dft_axis(line, N, 1, 0, -1);
        for (int k = 0; k < N; ++k) {
            const bool nyquist = N > 1 && 2 * k == N;
            line[k] = nyquist ? 0.0 : project ? line[k] : cd(0, signed_omega(k, N)) * line[k];
        }
        dft_axis(line, N, 1, 0, +1);
        for (int i = 0; i < n; ++i)
            m[std::size_t(i) * n + j] = line[i].real() / N;
    }
    return m;
}

// out = (A along x, B along y) v for a w x h field; A is w x w, B h x h.
std::vector<double> separable(const std::vector<double>& A, const std::vector<double>& B,
                              const std::vector<double>& v, int w, int h, bool transpose)
{
    auto at = [&](const std::vector<double>& M, int n, int i, int j) {
        return transpose ? M[std::size_t(j) * n + i] : M[std::size_t(i) * n + j];
    };
    std::vector<double> tmp(v.size(), 0.0), out(v.size(), 0.0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int j = 0; j < w; ++j)
                tmp[std::size_t(y) * w + x] += at(A, w, x, j) * v[std::size_t(y) * w + j];
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int j = 0; j < h; ++j)
                out[std::size_t(y) * w + x] += at(B, h, y, j) * tmp[std::size_t(j) * w + x];
    return out;
}

} // namespace

std::vector<double> poisson_weighted(const std::vector<double>& g, int w, int h,
                                     const std::vector<double>& wt, bool periodic, double eps)
{
    const std::size_t n = std::size_t(w) * h;
    const auto Dx = axis_operator(w, periodic, false), Px = axis_operator(w, periodic, true);
    const auto Dy = axis_operator(h, periodic, false), Py = axis_operator(h, periodic, true);
    std::vector<double> c(n), tx(n), ty(n);
    for (std::size_t i = 0; i < n; ++i) {
        c[i] = std::max(wt[i], eps);
        tx[i] = wt[i] / c[i] * g[2 * i];
        ty[i] = wt[i] / c[i] * g[2 * i + 1];
    }
    // G^T C (G v - t) = 0 for G v = (Dx (x) Py, Px (x) Dy) v.
    auto gradient_adjoint = [&](const std::vector<double>& ax, const std::vector<double>& ay) {
        auto a = separable(Dx, Py, ax, w, h, true);
        auto b = separable(Px, Dy, ay, w, h, true);
        for (std::size_t i = 0; i < n; ++i)
            a[i] += b[i];
        return a;
    };
    auto apply = [&](const std::vector<double>& v) {
        auto gx = separable(Dx, Py, v, w, h, false), gy = separable(Px, Dy, v, w, h, false);
        for (std::size_t i = 0; i < n; ++i) {
            gx[i] *= c[i];
            gy[i] *= c[i];
        }
        return gradient_adjoint(gx, gy);
    };
    std::vector<double> cx(n), cy(n);
    for (std::size_t i = 0; i < n; ++i) {
        cx[i] = c[i] * tx[i];
        cy[i] = c[i] * ty[i];
    }
    std::vector<double> b = gradient_adjoint(cx, cy), x(n, 0.0);
    auto dot = [&](const std::vector<double>& a, const std::vector<double>& e) {
        double s = 0;
        for (std::size_t i = 0; i < n; ++i)
            s += a[i] * e[i];
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
    double mean = 0;
    for (double v : x)
        mean += v;
    mean /= double(n);
    for (double& v : x)
        v -= mean;
    return x;
}

} // namespace relief::reference
