// SPDX-License-Identifier: Apache-2.0
// Which tiles of the slope field have any non-zero slope (docs/design.md §6:
// content that needs no integration is skipped). common.h is prepended by
// the host. One work-item per tile of tile x tile texels.
__kernel void nonflat_tiles(__global const float2* slopes, int width, int height, int tile, int tiles_x,
                            int tiles_y, __global uchar* nonflat)
{
    int t = get_global_id(0);
    if (t >= tiles_x * tiles_y)
        return;
    int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
    int x1 = min(x0 + tile, width), y1 = min(y0 + tile, height);
    uchar any = 0;
    for (int y = y0; y < y1 && !any; ++y)
        for (int x = x0; x < x1; ++x) {
            float2 g = slopes[y * width + x];
            if (g.x != 0.0f || g.y != 0.0f) {
                any = 1;
                break;
            }
        }
    nonflat[t] = any;
}
