// SPDX-License-Identifier: Apache-2.0
// Radial ray integration, reference kernel (docs/design.md §4.2).
// common.h is prepended by the host.
//
// Every ray of one direction crosses the same texel offsets with the same
// segment lengths, because all rays start at a texel centre; the host walks
// each direction once and passes the table:
//   dir_start[j] .. dir_start[j+1]  segments of direction j, in walk order;
//   seg_offset[s] = texel offset (dx, dy) from the ray's origin;
//   seg_data[s]   = (extent x, extent y, weight, cumulative weight).
// Segment 0 of every direction is the origin texel: it raises the height
// along the ray but has weight 0 (p is excluded from its own mean).
// active[tile] = 0 marks tiles whose rays cross only zero slopes: skipped.
// The displacement of p is minus the weighted mean of the midpoint heights
// relative to p; the host removes the global mean afterwards.
//
// Sums run in double where the device has fp64 (RELIEF_FP64), else in
// float with Kahan compensation: plain float sums over a 65536-texel ray
// were off by 2e-3 of max|h|.

typedef relief_acc_t acc_t;  // (common.h)

// s += v, compensated: c carries the low-order bits lost so far.
inline void acc_add(acc_t* s, acc_t* c, acc_t v)
{
    const acc_t y = v - *c;
    const acc_t t = *s + y;
    *c = (t - *s) - y;
    *s = t;
}

__kernel void rays_reference(__global const float2* slopes, int width, int height, int row0, int rows,
                             int periodic, int directions, __global const int* dir_start,
                             __global const int2* seg_offset, __global const float4* seg_data,
                             __global const uchar* active, int tile, int tiles_x,
                             __global float* displacement)
{
    int gid = get_global_id(0);
    if (gid >= width * rows)
        return;
    int x = gid % width;
    int y = row0 + gid / width;
    // Every ray of a texel in an inactive tile crosses only zero slopes.
    if (!active[(y / tile) * tiles_x + x / tile]) {
        displacement[y * width + x] = 0.0f;
        return;
    }

    acc_t sum_a = 0, sum_ac = 0, sum_w = 0, sum_wc = 0;
    for (int j = 0; j < directions; ++j) {
        acc_t h = 0, hc = 0, a = 0, ac = 0;
        float w = 0.0f;
        int end = dir_start[j + 1];
        for (int s = dir_start[j]; s < end; ++s) {
            int2 o = seg_offset[s];
            int qx = x + o.x, qy = y + o.y;
            if (periodic) {
                qx = relief_wrap(qx, width);
                qy = relief_wrap(qy, height);
            } else if (qx < 0 || qx >= width || qy < 0 || qy >= height) {
                break;  // clip: the ray leaves the texture here
            }
            float2 g = slopes[qy * width + qx];
            float4 d = seg_data[s];
            acc_t dh = (acc_t)g.x * d.x + (acc_t)g.y * d.y;
            acc_add(&a, &ac, (acc_t)d.z * (h + (acc_t)0.5 * dh));
            acc_add(&h, &hc, dh);
            w = d.w;
        }
        acc_add(&sum_a, &sum_ac, a);
        acc_add(&sum_w, &sum_wc, (acc_t)w);
    }
    displacement[y * width + x] = sum_w > 0 && sum_a != 0 ? (float)(-sum_a / sum_w) : 0.0f;
}
