// SPDX-License-Identifier: Apache-2.0
// Checking a result (docs/design.md §9): a height's own normals (the inverse of
// the DDM, §4.1), the round trip against the slopes a height came from, and
// per-patch tessellation levels.
//
// Heights are in texel units. Differences are central, (h[x+1] - h[x-1])/2,
// wrapping along an axis the map tiles along; at the edges across which it
// does not tile they are one-sided (h[1] - h[0], h[n-1] - h[n-2]), and 0 across a single texel.

inline float check_difference(global const float* h, int row, int stride, int i, int n, int periodic)
{
    if (n < 2)
        return 0.0f;
    if (periodic)
        return 0.5f * (h[row + relief_wrap(i + 1, n) * stride] - h[row + relief_wrap(i - 1, n) * stride]);
    if (i == 0)
        return h[row + stride] - h[row];
    if (i == n - 1)
        return h[row + i * stride] - h[row + (i - 1) * stride];
    return 0.5f * (h[row + (i + 1) * stride] - h[row + (i - 1) * stride]);
}

// The height's slope (gx, gy) at texel (i, j), in texels per texel.
inline float2 check_gradient(global const float* h, int w, int ht, int i, int j, int periodic_x,
                             int periodic_y)
{
    return (float2)(check_difference(h, j * w, 1, i, w, periodic_x),
                    check_difference(h, i, w, j, ht, periodic_y));
}

// height -> unit normals, 3 floats per texel: n = normalize(-s gx, -s gy, 1)
// in the image frame, its row component times `row_sign` (-1: OpenGL's
// G = -n_y, +1: DirectX's G = +n_y).
kernel void height_normals(global const float* h, int w, int ht, int periodic_x, int periodic_y, float scale,
                           float row_sign, global float* out)
{
    const int gid = get_global_id(0);
    if (gid >= w * ht)
        return;
    const float2 g = scale * check_gradient(h, w, ht, gid % w, gid / w, periodic_x, periodic_y);
    const float3 n = normalize((float3)(-g.x, -g.y, 1.0f));
    out[3 * (size_t)gid + 0] = n.x;
    out[3 * (size_t)gid + 1] = row_sign * n.y;
    out[3 * (size_t)gid + 2] = n.z;
}

// The round trip of a height against the slopes g it was integrated from:
// per texel the angle (degrees) between the normals (-g, 1) and (-grad h, 1),
// and (|g - grad h|^2, |g|^2) for the residual share.
kernel void round_trip(global const float2* g, global const float* h, int w, int ht, int periodic_x,
                       int periodic_y, global float* angle, global float2* residual)
{
    const int gid = get_global_id(0);
    if (gid >= w * ht)
        return;
    const float2 gi = g[gid];
    const float2 gh = check_gradient(h, w, ht, gid % w, gid / w, periodic_x, periodic_y);
    const float3 a = (float3)(-gi.x, -gi.y, 1.0f), b = (float3)(-gh.x, -gh.y, 1.0f);
    // atan2 of |a x b| and a.b keeps small angles accurate (acos does not).
    angle[gid] = degrees(atan2(length(cross(a, b)), dot(a, b)));
    const float2 d = gi - gh;
    residual[gid] = (float2)(dot(d, d), dot(gi, gi));
}

// Height at continuous texel coordinates (x, y): texel (i, j) sits at
// (i + 0.5, j + 0.5); bilinear, clamped at the edges.
inline float check_bilinear(global const float* h, int w, int ht, float x, float y)
{
    const float tx = x - 0.5f, ty = y - 0.5f;
    const float fx0 = floor(tx), fy0 = floor(ty);
    const float fx = tx - fx0, fy = ty - fy0;
    const int i0 = clamp((int)fx0, 0, w - 1), i1 = clamp((int)fx0 + 1, 0, w - 1);
    const int j0 = clamp((int)fy0, 0, ht - 1), j1 = clamp((int)fy0 + 1, 0, ht - 1);
    const float top = mix(h[j0 * w + i0], h[j0 * w + i1], fx);
    const float bottom = mix(h[j1 * w + i0], h[j1 * w + i1], fx);
    return mix(top, bottom, fy);
}

// The largest level a patch can have.
#define CHECK_MAX_LEVEL 64

// Whether level L of the patch [x0, x1] x [y0, y1] (texel corners) keeps
// the displaced surface within `error` of scale * h at every texel centre
// of the patch: the patch split into L x L quads with vertex heights
// sampled bilinearly from scale * h, each quad cut along the diagonal that
// points away from the patch centre (the main diagonal in the top-left and
// bottom-right quarters), so a patch corner is always a diagonal's end and
// no triangle of a patch with L >= 2 has two edges on the patch border: the
// mesh's stitching relies on that. Stops at the first texel off by more.
inline int check_level_passes(global const float* h, int w, int ht, int x0, int y0, int x1, int y1, int L,
                              float error, float scale)
{
    const float sx = (float)(x1 - x0) / (float)L, sy = (float)(y1 - y0) / (float)L;
    for (int j = y0; j < y1; ++j) {
        const float v = ((float)j + 0.5f - (float)y0) / sy;
        const int b = min((int)v, L - 1);
        const float fv = v - (float)b;
        const float ya = (float)y0 + sy * (float)b, yb = (float)y0 + sy * (float)(b + 1);
        // The corners of the current cell, fetched again only when the
        // texels move into the next cell of the row.
        int a = -1;
        float z00 = 0.0f, z10 = 0.0f, z01 = 0.0f, z11 = 0.0f;
        for (int i = x0; i < x1; ++i) {
            const float u = ((float)i + 0.5f - (float)x0) / sx;
            const int ai = min((int)u, L - 1);
            const float fu = u - (float)ai;
            if (ai != a) {
                a = ai;
                const float xa = (float)x0 + sx * (float)a, xb = (float)x0 + sx * (float)(a + 1);
                z00 = scale * check_bilinear(h, w, ht, xa, ya);
                z10 = scale * check_bilinear(h, w, ht, xb, ya);
                z01 = scale * check_bilinear(h, w, ht, xa, yb);
                z11 = scale * check_bilinear(h, w, ht, xb, yb);
            }
            float z;
            if ((2 * a < L) == (2 * b < L))  // main diagonal, 00 - 11
                z = fu >= fv ? z00 + fu * (z10 - z00) + fv * (z11 - z10)
                             : z00 + fv * (z01 - z00) + fu * (z11 - z01);
            else  // the other diagonal, 10 - 01
                z = fu + fv <= 1.0f ? z00 + fu * (z10 - z00) + fv * (z01 - z00)
                                    : z11 + (1.0f - fu) * (z01 - z11) + (1.0f - fv) * (z10 - z11);
            if (fabs(z - scale * h[j * w + i]) > error)
                return 0;
        }
    }
    return 1;
}

// Whether every texel of the patch has the same height: such a patch is
// level 1 whatever its corners read from the neighbours (nothing to
// tessellate).
inline int check_flat(global const float* h, int w, int x0, int y0, int x1, int y1)
{
    const float h0 = h[y0 * w + x0];
    for (int j = y0; j < y1; ++j)
        for (int i = x0; i < x1; ++i)
            if (h[j * w + i] != h0)
                return 0;
    return 1;
}

// Per patch of patch x patch texels (the last row and column of patches
// may be narrower): the lowest level in 1..64 that passes, or 0 when none
// does; flat patches are level 1. Two launch shapes give the same levels:
// tessellation_levels, one work-item per patch scanning the levels upward
// (a failing level usually stops within a few texels: about one full pass
// per patch), for maps with many patches; tessellation_pass, one work-item
// per patch and level (the host takes the lowest that passes), for few
// large patches, whose levels would otherwise run one after another.
kernel void tessellation_levels(global const float* h, int w, int ht, int patch, float error, float scale,
                                int patches_x, int patch_count, global uchar* level)
{
    const int p = get_global_id(0);
    if (p >= patch_count)
        return;
    const int x0 = (p % patches_x) * patch, y0 = (p / patches_x) * patch;
    const int x1 = min(x0 + patch, w), y1 = min(y0 + patch, ht);
    uchar found = check_flat(h, w, x0, y0, x1, y1) ? 1 : 0;
    for (int L = 1; L <= CHECK_MAX_LEVEL && !found; ++L)
        if (check_level_passes(h, w, ht, x0, y0, x1, y1, L, error, scale))
            found = (uchar)L;
    level[p] = found;
}

kernel void tessellation_pass(global const float* h, int w, int ht, int patch, float error, float scale,
                              int patches_x, int patch_count, global uchar* pass)
{
    const int gid = get_global_id(0);
    if (gid >= patch_count * CHECK_MAX_LEVEL)
        return;
    const int p = gid / CHECK_MAX_LEVEL, L = gid % CHECK_MAX_LEVEL + 1;
    const int x0 = (p % patches_x) * patch, y0 = (p / patches_x) * patch;
    const int x1 = min(x0 + patch, w), y1 = min(y0 + patch, ht);
    pass[gid] = (L == 1 && check_flat(h, w, x0, y0, x1, y1)) ||
                check_level_passes(h, w, ht, x0, y0, x1, y1, L, error, scale);
}
