// SPDX-License-Identifier: Apache-2.0
#include "tiling.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

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
    e.tiles = e.seam >= kTilingCorrelationFraction * e.adjacent && e.seam >= 2.0 / std::sqrt(count);
    return e;
}

}  // namespace

TilingEvidence tiling_evidence(const float* slopes, int w, int h)
{
    TilingEvidence e;
    e.x = axis_evidence(slopes, w, 1, h, std::size_t(w));  // columns
    e.y = axis_evidence(slopes, h, std::size_t(w), w, 1);  // rows
    e.tiles = e.x.tiles && e.y.tiles;
    return e;
}

}  // namespace relief::host
