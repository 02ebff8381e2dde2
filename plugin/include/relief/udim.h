// SPDX-License-Identifier: Apache-2.0
#pragma once
// UDIM sets: the tiles of one texture, numbered as oiiotool and Mari number
// them, 1001 + u + 10 v (u in 0..9 to the right, v up: 1011 sits above
// 1001). A set integrated as one surface has no steps at its tile borders.
#include <OpenImageIO/imagebuf.h>

#include <string>
#include <vector>

#include "height.h"

#include "relief/export.h"

namespace relief {

struct UdimTile {
    int number = 1001;                        // 1001..1999 (u = (n-1001) % 10, v = (n-1001) / 10)
    const OIIO::ImageBuf* normals = nullptr;  // not owned
};

// A pair of tiles that share an edge: `a` left of `b` (same v, u + 1) or
// below it (same u, v + 1).
struct UdimEdge {
    int a = 0, b = 0;
    bool joined = false;
    // The wrap-seam slope test across the edge (docs/design.md §4.4.3):
    // |r| of the slopes on the two lines that meet there, and of
    // neighbouring lines inside the two tiles.
    double seam = 0.0, adjacent = 0.0;
};

struct UdimReport {
    std::string mode;                      // "joint", "each" or "auto"
    std::vector<UdimEdge> edges;           // every shared edge of the set (auto)
    std::vector<std::vector<int>> groups;  // the tile numbers solved together, each ascending
};

// The height of every tile of a UDIM set under options.udim (relief/height.h):
// dst[i] is tiles[i]'s height, as height() would make it for that tile
// alone (Each, or a tile every edge of which is cut: the same bits), or
// cut out of the joint solve of its group. A group's canvas spans the
// bounding box of its tiles; a missing tile, and a tile of another group,
// takes weight 0 (the mask path of docs/design.md §4.4.2), so a full
// rectangular set joined equals the solve of the assembled map. The outer
// boundary is options.boundary applied to the canvas. Heights are zero mean
// over each group, not each tile. Joined tiles must share their size, channel
// count and pixel type. A mask image (options.mask) weights one tile: Joint
// refuses it, Auto then solves every tile alone; mask=alpha (each tile's
// alpha) works in every mode. options.report describes the last group. Memory for the
// canvas is estimated and refused, with the numbers, before anything is
// allocated. Results carry relief:udim ("joint 1001,1002" or "alone").
// On failure dst is left empty and geterror() says why.
RELIEF_API bool height_udim(std::vector<OIIO::ImageBuf>& dst, const std::vector<UdimTile>& tiles,
                            const HeightOptions& options = {}, UdimReport* report = nullptr);
RELIEF_API std::vector<OIIO::ImageBuf> height_udim(const std::vector<UdimTile>& tiles,
                                                   const HeightOptions& options = {},
                                                   UdimReport* report = nullptr);

}  // namespace relief
