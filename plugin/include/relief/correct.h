// SPDX-License-Identifier: Apache-2.0
#pragma once
// Distortion correction: displacement (height) map -> texture-coordinate
// offset map (docs/design.md §4.5, after Zirr & Ritschel, "Distortion-Free
// Displacement Mapping", HPG 2019).
#include <OpenImageIO/imagebuf.h>

#include <string>
#include <vector>

#include "correct_types.h"
#include "options.h"

#include "relief/export.h"

namespace relief {

// Corner: nodes at texel corners with bilinear heights; the offset of a
// texel is the mean of its four corners' (the reference tool's default).
// Center: one node per texel centre, with the texel's height.
enum class CorrectNodes { Corner, Center };
// Periodic: the texture tiles along the axis (the mesh wraps). Fixed: the
// border nodes at the axis's two ends stay put. Auto: periodic when the
// height jumps across that axis's wrap seam no more than twice the mean jump
// between neighbouring texels; the choice is reported.
enum class CorrectBoundary { Auto, Periodic, Fixed };
// A boundary for each axis, x first, as relief::Boundaries for height():
// one value sets both axes, and compared with one value both must have it.
struct CorrectBoundaries {
    CorrectBoundary x = CorrectBoundary::Auto, y = CorrectBoundary::Auto;
    constexpr CorrectBoundaries(CorrectBoundary both = CorrectBoundary::Auto) : x(both), y(both) {}
    constexpr CorrectBoundaries(CorrectBoundary along_x, CorrectBoundary along_y) : x(along_x), y(along_y) {}
    friend constexpr bool operator==(const CorrectBoundaries& a, const CorrectBoundaries& b)
    {
        return a.x == b.x && a.y == b.y;
    }
    friend constexpr bool operator!=(const CorrectBoundaries& a, const CorrectBoundaries& b)
    {
        return !(a == b);
    }
};
struct CorrectOptions {
    // World height = scale * stored height, the texture's width spanning one
    // world unit (square texels). 0 = auto: 1/width for relief's own height
    // maps (stored in texels), otherwise an error asking for a scale.
    float scale = 0.0f;
    float theta = 5.0f;  // area exponent, 0..20
    CorrectNodes nodes = CorrectNodes::Corner;
    CorrectBoundaries boundary = CorrectBoundary::Auto;
    // Fixation (optional): texels with weight w stay within 1/w texels of
    // where they started. Either channel 0 of `fix_mask` (same size, values
    // >= 0; not owned) or a tent over the stored height: w = max(0, 1 -
    // |h - fix_height| / fix_width) when fix_width > 0.
    const OIIO::ImageBuf* fix_mask = nullptr;
    float fix_height = 0.0f, fix_width = 0.0f;
    int iterations = 0;  // per pyramid level; 0 = auto (until the tolerance)
    // Auto stops when the relative energy change per pass over the nodes
    // (the node phases, or a global step) is below this; the finest level
    // also when its next change, shrinking at the rate of the last ones,
    // is predicted below it.
    float tolerance = 2e-5f;
    // Per level, for auto: node iterations, each hat sweep and global step
    // counted as the iterations it costs (2.5 a scale of hats, 0.5 a step).
    int max_iterations = 1000;
    int levels = 0;  // coarse-to-fine levels; 0 = auto (down to 16 texels), 1 = off
    // Nothing is corrected when no triangle's anisotropy s1/s2 - 1 or area
    // change |s1 s2 - 1| exceeds this (zero offsets, no solve).
    float threshold = 1e-3f;
    bool skip_tiles = true;  // skip tiles whose nodes cannot move (identical result)
    CorrectSearch search = CorrectSearch::Brent;
    // Over-relaxation factor in [1, 2): a node moves `relax` times its
    // searched step when that also lowers the energy (1 = plain steps).
    float relax = 1.5f;
    CorrectHats hats = CorrectHats::Off;
    CorrectGlobal global = CorrectGlobal::Auto;
    // nodes=corner: after the solve, node iterations on the delivered mesh
    // (the texel centres, started from the means of their four corners), each
    // move lowering its energy. 0: the output is the corner means.
    int polish = 2;
    CorrectReport* report = nullptr;  // filled when given
    Execution exec;
};

// Computes the offset map of a height map (channel 0): 2 float channels
// "du", "dv" in texture units (1 = the texture's width, height): the
// surface point at texture coordinate u shows the texture at u + c(u).
// Metadata: relief:method "correct", relief:boundary, relief:nodes,
// relief:scale, relief:parameters. roi/nthreads/errors as in relief::slopes().
RELIEF_API OIIO::ImageBuf correct(const OIIO::ImageBuf& height, const CorrectOptions& options = {},
                                  OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool correct(OIIO::ImageBuf& dst, const OIIO::ImageBuf& height, const CorrectOptions& options = {},
                        OIIO::ROI roi = {}, int nthreads = 0);

}  // namespace relief
