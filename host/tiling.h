#pragma once
// Does a texture tile? Evidence from its slope field (DESIGN.md §4.4,
// boundary=auto): across the wrap seam of a tiling texture the slopes change
// as little as between any two neighbours; a texture cut out of something
// larger jumps there.
namespace relief::host {

struct TilingEvidence {
    double seam_ratio_x = 1.0;  // mean |g jump| across the left/right seam / mean interior jump
    double seam_ratio_y = 1.0;  // the same across the top/bottom seam
    bool tiles = true;          // both ratios <= kTilingSeamRatio
};

// Seams that jump more than this many times the typical interior jump make
// the texture non-tiling.
constexpr double kTilingSeamRatio = 1.5;

// slopes: gx, gy per texel, row-major. Axes shorter than 3 texels count as
// tiling (there is no interior to compare with).
TilingEvidence tiling_evidence(const float* slopes, int width, int height);

} // namespace relief::host
