#include "tiling.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace relief::host {

namespace {

double jump(const float* g, std::size_t a, std::size_t b)
{
    // Not std::hypot: its overflow care costs 5x here, and slopes are bounded.
    const double dx = double(g[2 * a]) - g[2 * b], dy = double(g[2 * a + 1]) - g[2 * b + 1];
    return std::sqrt(dx * dx + dy * dy);
}

// Mean jump across the seam / mean interior jump along one axis; `step`
// moves along the axis, `lines`/`line_step` enumerate the lines across it.
double seam_ratio(const float* g, int length, int lines, std::size_t step, std::size_t line_step)
{
    if (length < 3)
        return 1.0;
    // Every line's seam; the interior of up to 256 evenly spread lines is a
    // plenty good estimate of the typical jump.
    const int every = std::max(1, lines / 256);
    double seam = 0.0, interior = 0.0;
    int sampled = 0;
    for (int l = 0; l < lines; ++l) {
        const std::size_t first = std::size_t(l) * line_step;
        seam += jump(g, first, first + std::size_t(length - 1) * step);
        if (l % every)
            continue;
        for (int i = 0; i + 1 < length; ++i)
            interior += jump(g, first + i * step, first + (i + 1) * step);
        ++sampled;
    }
    seam /= lines;
    interior /= double(sampled) * (length - 1);
    if (interior <= 0.0)
        return seam > 0.0 ? INFINITY : 1.0;
    return seam / interior;
}

} // namespace

TilingEvidence tiling_evidence(const float* slopes, int w, int h)
{
    TilingEvidence e;
    e.seam_ratio_x = seam_ratio(slopes, w, h, 1, std::size_t(w));
    e.seam_ratio_y = seam_ratio(slopes, h, w, std::size_t(w), 1);
    e.tiles = e.seam_ratio_x <= kTilingSeamRatio && e.seam_ratio_y <= kTilingSeamRatio;
    return e;
}

} // namespace relief::host
