// SPDX-License-Identifier: Apache-2.0
#include "poisson/tiling.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace relief::host {

namespace {

// |correlation| of slope component c along lines a and b (each `count`
// texels, `stride` apart).
double line_correlation(const float* g, std::size_t a, std::size_t b, int count, std::size_t stride, int c)
{
    double ma = 0, mb = 0;
    for (int i = 0; i < count; ++i) {
        ma += g[2 * (a + i * stride) + c];
        mb += g[2 * (b + i * stride) + c];
    }
    ma /= count;
    mb /= count;
    double sab = 0, saa = 0, sbb = 0;
    for (int i = 0; i < count; ++i) {
        const double da = g[2 * (a + i * stride) + c] - ma, db = g[2 * (b + i * stride) + c] - mb;
        sab += da * db;
        saa += da * da;
        sbb += db * db;
    }
    return saa > 0 && sbb > 0 ? std::abs(sab) / std::sqrt(saa * sbb) : 0.0;
}

// Lines run across the axis: `lines` of them, `line_step` apart, each
// `count` texels with `stride` between texels.
AxisEvidence axis_evidence(const float* g, int lines, std::size_t line_step, int count, std::size_t stride)
{
    AxisEvidence e;
    if (lines < 3 || count < 3)
        return e;
    auto both = [&](std::size_t a, std::size_t b) {
        return 0.5 *
               (line_correlation(g, a, b, count, stride, 0) + line_correlation(g, a, b, count, stride, 1));
    };
    e.seam = both(std::size_t(lines - 1) * line_step, 0);
    const int samples = std::min(lines - 1, 64);
    for (int s = 0; s < samples; ++s) {
        const std::size_t l = std::size_t(s) * (lines - 2) / std::max(samples - 1, 1);
        e.adjacent += both(l * line_step, (l + 1) * line_step);
    }
    e.adjacent /= samples;
    e.slopes_tile = e.seam >= kTilingCorrelationFraction * e.adjacent && e.seam >= 2.0 / std::sqrt(count);
    return e;
}

// The orthonormal DCT-II basis of length n: row k is the k-th eigenvector
// of the path graph's Laplacian (free ends), eigenvalue 2 - 2 cos(pi k / n).
std::vector<double> dct_basis(int n)
{
    std::vector<double> c(std::size_t(n) * n);
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            c[std::size_t(k) * n + j] = std::sqrt((k ? 2.0 : 1.0) / n) * std::cos(M_PI * k * (j + 0.5) / n);
    return c;
}

// The r x c product op(a) op(b), op transposing where asked; op(a) is
// r x k, op(b) k x c, all row-major.
std::vector<double> product(const std::vector<double>& a, bool ta, const std::vector<double>& b, bool tb,
                            int r, int k, int c)
{
    std::vector<double> out(std::size_t(r) * c, 0.0);
    for (int i = 0; i < r; ++i)
        for (int j = 0; j < c; ++j) {
            double v = 0;
            for (int q = 0; q < k; ++q)
                v += (ta ? a[std::size_t(q) * r + i] : a[std::size_t(i) * k + q]) *
                     (tb ? b[std::size_t(j) * k + q] : b[std::size_t(q) * c + j]);
            out[std::size_t(i) * c + j] = v;
        }
    return out;
}

// Heights of an m x n grid of blocks whose slopes (height change per block)
// are bx, by: the discrete least squares with free edges, each step between
// neighbours fitted to the mean of their two slopes. Solved exactly in the
// DCT basis (the grid is small: about 100 blocks a side).
std::vector<double> block_heights(const std::vector<double>& bx, const std::vector<double>& by, int m, int n)
{
    // The normal equations L h = d, d[p] = (targets of edges ending at p) -
    // (targets of edges starting at p).
    std::vector<double> d(std::size_t(m) * n, 0.0);
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < n; ++j) {
            const std::size_t p = std::size_t(i) * n + j;
            if (j + 1 < n) {
                const double t = 0.5 * (bx[p] + bx[p + 1]);
                d[p] -= t;
                d[p + 1] += t;
            }
            if (i + 1 < m) {
                const double t = 0.5 * (by[p] + by[p + n]);
                d[p] -= t;
                d[p + n] += t;
            }
        }
    const std::vector<double> cy = dct_basis(m), cx = dct_basis(n);
    // Into the basis (rows, then columns), divided by the eigenvalues, back.
    std::vector<double> s = product(cy, false, product(d, false, cx, true, m, n, n), false, m, m, n);
    for (int l = 0; l < m; ++l)
        for (int k = 0; k < n; ++k) {
            const double lambda = (2 - 2 * std::cos(M_PI * k / n)) + (2 - 2 * std::cos(M_PI * l / m));
            double& v = s[std::size_t(l) * n + k];
            v = l == 0 && k == 0 ? 0.0 : v / lambda;
        }
    const std::vector<double> h = product(product(cy, true, s, false, m, m, n), false, cx, false, m, n, n);
    return h;
}

// rms of the heights' step across the seam between the last and the first
// block of each line along the axis, over the rms of the steps between
// neighbouring blocks, both less the mean slope (a tilt every step shares:
// the periodic solve drops it, so it is no evidence either way). lines x
// count blocks, `along` the stride between blocks of a line, `across`
// between lines.
double height_step(const std::vector<double>& h, const std::vector<double>& slope, int lines, int count,
                   std::size_t along, std::size_t across)
{
    double tilt = 0;
    for (double v : slope)
        tilt += v;
    tilt /= double(slope.size());
    double seam = 0, steps = 0;
    for (int l = 0; l < lines; ++l) {
        const double* line = h.data() + l * across;
        const double s = line[0] - line[(count - 1) * along] + tilt * (count - 1);
        seam += s * s;
        for (int k = 0; k + 1 < count; ++k) {
            const double n = line[(k + 1) * along] - line[k * along] - tilt;
            steps += n * n;
        }
    }
    seam /= lines;
    steps /= double(lines) * (count - 1);
    return steps > 0 ? std::sqrt(seam / steps) : 0.0;
}

bool verdict(const AxisEvidence& e)
{
    if (e.slopes_tile)
        return e.height_step <= kSlopesBelievedStep;
    if (e.adjacent >= kSmoothAdjacent && e.seam < kCleanBreakFraction * e.adjacent)
        return false;
    return e.height_step <= kTilingHeightStep;
}

}  // namespace

TilingEvidence tiling_evidence(const float* slopes, int w, int h)
{
    TilingEvidence e;
    e.x = axis_evidence(slopes, w, 1, h, std::size_t(w));  // columns
    e.y = axis_evidence(slopes, h, std::size_t(w), w, 1);  // rows

    const int b = std::max(1, int(std::lround(double(std::max(w, h)) / kTilingBlocks)));
    const int n = w / b, m = h / b;
    if (n >= 3 && m >= 3) {
        std::vector<double> bx(std::size_t(m) * n, 0.0), by(bx.size(), 0.0);
        for (int y = 0; y < m * b; ++y)
            for (int x = 0; x < n * b; ++x) {
                const std::size_t p = std::size_t(y / b) * n + x / b, t = 2 * (std::size_t(y) * w + x);
                bx[p] += slopes[t];
                by[p] += slopes[t + 1];
            }
        // Mean slope over the block times its side: the height change per block.
        for (std::size_t p = 0; p < bx.size(); ++p) {
            bx[p] /= double(b);
            by[p] /= double(b);
        }
        const std::vector<double> hb = block_heights(bx, by, m, n);
        e.x.height_step = height_step(hb, bx, m, n, 1, std::size_t(n));
        e.y.height_step = height_step(hb, by, n, m, std::size_t(n), 1);
    }
    e.x.tiles = verdict(e.x);
    e.y.tiles = verdict(e.y);
    e.tiles = e.x.tiles && e.y.tiles;
    return e;
}

}  // namespace relief::host
