// SPDX-License-Identifier: Apache-2.0
#pragma once
// Does a texture tile? Evidence from its slope field (boundary=auto), one
// axis at a time (docs/design.md §4.4.3).
//
// Two tests look at each wrap seam:
// - Slopes: across the seam of a tiling texture the slopes of the last and
//   the first column (row) are as closely related as those of two
//   neighbouring columns inside; in a texture cut out of something larger
//   they are as unrelated as two distant columns. The measure is the
//   correlation magnitude |r| of the slope components along the two lines
//   (magnitude, because a seam placed on a groove flips the sign). A plain
//   jump ratio fails on textures whose seam runs along grout or grain.
// - Block heights: a seam re-compressed, painted over or blurred loses its
//   texel-scale correlation (0ad_desert_cliff, re_conc02) while the surface
//   still meets itself. Slopes averaged over blocks (about a hundredth of
//   the longer side) are integrated by least squares with free edges; where
//   the map tiles, the heights step across the seam about as much as
//   between neighbouring blocks, where it is a crop they step by the height
//   difference of its two edges.
namespace relief::host {

struct AxisEvidence {
    double seam = 0.0;         // |r| across the seam
    double adjacent = 0.0;     // mean |r| of neighbouring interior lines
    bool slopes_tile = true;   // the slope test alone
    double height_step = 0.0;  // block heights: rms step across the seam / between neighbours (tilt removed)
    bool tiles = true;         // the axis's verdict from both tests
};

struct TilingEvidence {
    AxisEvidence x;  // the left/right seam (columns)
    AxisEvidence y;  // the top/bottom seam (rows)
    // Both axes tile: the one boundary rays take on auto.
    bool tiles = true;
};

// An axis passes the slope test when the seam correlates at least this
// fraction as well as neighbours do (and clearly above the noise of a
// correlation estimate, 2/sqrt(line length)).
constexpr double kTilingCorrelationFraction = 0.5;
// The block-heights test: an axis tiles when its seam steps at most this
// many times as much as neighbouring blocks do; slopes that pass their test
// are believed up to kSlopesBelievedStep.
constexpr double kTilingHeightStep = 2.0;
constexpr double kSlopesBelievedStep = 8.0;
// On a smooth map (neighbouring lines correlate at least kSmoothAdjacent) a
// seam that correlates under kCleanBreakFraction of that is a clean break:
// a tiling seam, however rough, keeps a smooth map's slopes related.
constexpr double kSmoothAdjacent = 0.6;
constexpr double kCleanBreakFraction = 0.25;
// Blocks along the longer side for the block-heights test.
constexpr int kTilingBlocks = 100;

// slopes: gx, gy per texel, row-major. Axes shorter than 3 texels (or 3
// blocks) count as tiling (there is no interior to compare with).
TilingEvidence tiling_evidence(const float* slopes, int width, int height);

}  // namespace relief::host
