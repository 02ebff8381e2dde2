// SPDX-License-Identifier: Apache-2.0
// The tiles ray integration cannot skip (docs/design.md §6; kernels/tiles.cl).
#include <algorithm>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include "errors.h"
#include "field_ops.h"
#include "rays/rays_parts.h"
#include "device/queue_wait.h"

namespace relief::host {

// One flag per kSkipTile^2 tile: 1 where the rays of its texels may cross a
// non-zero slope (a non-flat tile within `reach` texels), 0 where they cannot.
cl::Buffer active_tiles(ComputeContext::Impl& c, const DeviceSlopes& slopes, double reach, bool periodic,
                        bool skip, int& tiles_x, RayReport& report)
{
    const int w = slopes.width(), h = slopes.height(), T = kSkipTile;
    tiles_x = (w + T - 1) / T;
    const int tiles_y = (h + T - 1) / T;
    const std::size_t n = std::size_t(tiles_x) * tiles_y;
    std::vector<cl_uchar> flags(n, 1);
    if (skip) {
        cl::Buffer nonflat = c.buffer(CL_MEM_WRITE_ONLY, n, "ray integration");
        cl::Kernel k(c.program("tiles.cl"), "nonflat_tiles");
        set_args(k, slopes.impl().buffer, cl_int(w), cl_int(h), cl_int(T), cl_int(tiles_x), cl_int(tiles_y),
                 nonflat);
        c.launch(k, n);
        std::vector<cl_uchar> any(n);
        read_asking(c.queue, nonflat, 0, n, any.data());
        // Dilate by the reach in tiles (a square covers the disk), along x
        // then along y; periodic textures wrap.
        const int r = int(std::ceil(reach / T));
        auto dilate = [&](std::vector<cl_uchar>& v, int len, int lines, bool along_x) {
            std::vector<cl_uchar> out(v.size(), 0);
            for (int l = 0; l < lines; ++l)
                for (int i = 0; i < len; ++i) {
                    const std::size_t at =
                        along_x ? std::size_t(l) * tiles_x + i : std::size_t(i) * tiles_x + l;
                    if (!v[at])
                        continue;
                    for (int d = -std::min(r, len); d <= std::min(r, len); ++d) {
                        int j = i + d;
                        if (periodic)
                            j = ((j % len) + len) % len;
                        else if (j < 0 || j >= len)
                            continue;
                        out[along_x ? std::size_t(l) * tiles_x + j : std::size_t(j) * tiles_x + l] = 1;
                    }
                }
            v.swap(out);
        };
        dilate(any, tiles_x, tiles_y, true);
        dilate(any, tiles_y, tiles_x, false);
        flags = any;
    }
    report.tiles = n;
    report.skipped = std::size_t(std::count(flags.begin(), flags.end(), cl_uchar(0)));
    return c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n, "ray integration", flags.data());
}

}  // namespace relief::host
