// SPDX-License-Identifier: Apache-2.0
#pragma once
// The node grids of distortion correction (docs/design.md §4.5) and the plain CPU
// operations between them: node heights from texel heights, the
// coarse-to-fine pyramid (area downsampling, offset upsampling) and the
// per-texel offsets that are the stage's output. No OpenCL here.
#include <vector>

#include "periodic_axes.h"

namespace relief::host {

// Nodes at texel centres (one per texel) or at texel corners (the reference
// tool's default: W+1 along an axis with a fixed border, W along a periodic
// one, where the last corner is the first).
struct NodeGrid {
    int width = 0, height = 0;  // texels
    int nx = 0, ny = 0;         // nodes
    bool corner = false;
    Periodic periodic{false};

    NodeGrid() = default;
    NodeGrid(int texels_w, int texels_h, bool corner_nodes, Periodic periodic_axes);
    // Node (i, j)'s position in texture units (u spans [0, 1] across the width).
    double u(int i) const { return corner ? double(i) / width : (i + 0.5) / width; }
    double v(int j) const { return corner ? double(j) / height : (j + 0.5) / height; }
};

// Area-weighted resampling of a w x h field to w2 x h2 (w2 <= w, h2 <= h):
// every output texel is the mean over the input area it covers.
std::vector<float> area_downsample(const std::vector<float>& src, int w, int h, int w2, int h2);

// Per-node values of a per-texel field: the texel's value (centre nodes) or
// the mean of the up to four texels around the corner (wrapping along a
// periodic axis, clamped along a fixed one).
std::vector<float> node_values(const std::vector<float>& texels, const NodeGrid& g);

// Offsets (float2 per node, texture units) of `coarse` interpolated
// bilinearly at the nodes of `fine`; fixed-boundary border nodes get zero.
std::vector<float> upsample_offsets(const std::vector<float>& coarse, const NodeGrid& from,
                                    const NodeGrid& to);

// The offset at every texel centre (float2, texture units): the node's own
// (centre nodes) or the mean of the texel's four corners (corner nodes:
// the offsets are read half a texel shifted).
std::vector<float> texel_offsets(const std::vector<float>& node_offsets, const NodeGrid& g);

// The triangles of `g`'s mesh with offsets c (float2 per node, in texels)
// whose texture area is not positive (flipped or degenerate), each once,
// as the node that owns it (docs/design.md §4.5.1: [p, p+(1,0), p+(1,-1)]
// is triangle 0, [p, p+(1,-1), p+(0,-1)] triangle 1) times 2 plus its index.
std::vector<long long> flipped_triangles(const std::vector<float>& c, const NodeGrid& g);

// Unflips the mesh: each movable corner of a flipped triangle (in index
// order, round after round) moves towards the mean of its neighbours'
// offsets by 1/4, 1/2, 3/4 or all the way, whichever leaves the fewest
// flipped triangles around it (the shortest of equals), when that is fewer
// than before. Stops when nothing is flipped, nothing moved in a round, or
// after `rounds`. Returns the moves made. c: float2 per node, in texels.
int unflip_mesh(std::vector<float>& c, const NodeGrid& g, int rounds);

// Texel sizes of the pyramid, finest first: each level halves (rounding up)
// while both sides of the next stay >= min_side; at most `levels` (0 = no
// limit, 1 = single resolution).
std::vector<std::pair<int, int>> pyramid_sizes(int w, int h, int levels, int min_side = 16);

}  // namespace relief::host
