// SPDX-License-Identifier: Apache-2.0
// Baking the correction (docs/design.md §4.5, "Application"): the texel at u
// takes the texture's value at u + c(u), a gather (no inversion needed).
// Texel-centre coordinates: texel i's centre is u = (i + 0.5)/W, so u + c
// lands at texel coordinate i + c.u * W. Zero offsets read every texel
// back exactly (the weights are then 1 and 0).

inline int bake_index(int v, int n, int periodic)
{
    return periodic ? relief_wrap(v, n) : clamp(v, 0, n - 1);
}

// Catmull-Rom weights at fraction f (interpolating: f = 0 gives 0, 1, 0, 0).
inline float4 bake_cubic_weights(float f)
{
    const float f2 = f * f, f3 = f2 * f;
    return (float4)(-0.5f * f3 + f2 - 0.5f * f, 1.5f * f3 - 2.5f * f2 + 1.0f,
                    -1.5f * f3 + 2.0f * f2 + 0.5f * f, 0.5f * f3 - 0.5f * f2);
}

// src, dst: w x h texels of nch interleaved floats; offsets: float2 per
// texel in texture units; periodic: bit 0 x wraps, bit 1 y wraps (else
// reads clamp at that axis's edges).
kernel void bake_gather(global const float* src, int w, int h, int nch, global const float2* offsets,
                        int periodic, int bicubic, global float* dst)
{
    const int gid = get_global_id(0);
    if (gid >= w * h)
        return;
    const int i = gid % w, j = gid / w;
    const float2 c = offsets[gid];
    const float x = (float)i + c.x * (float)w, y = (float)j + c.y * (float)h;
    const float fx0 = floor(x), fy0 = floor(y);
    const float fx = x - fx0, fy = y - fy0;
    const int x0 = (int)fx0, y0 = (int)fy0;
    if (!bicubic) {
        const int xa = bake_index(x0, w, periodic & 1), xb = bake_index(x0 + 1, w, periodic & 1);
        const int ya = bake_index(y0, h, periodic & 2), yb = bake_index(y0 + 1, h, periodic & 2);
        for (int ch = 0; ch < nch; ++ch) {
            // size_t: texels x channels may pass 2^31 (a 32768^2 RGB map).
            const float v00 = src[((size_t)ya * w + xa) * nch + ch];
            const float v10 = src[((size_t)ya * w + xb) * nch + ch];
            const float v01 = src[((size_t)yb * w + xa) * nch + ch];
            const float v11 = src[((size_t)yb * w + xb) * nch + ch];
            // Lerp form: exact at fx = 0 or fy = 0.
            const float top = fx == 0.0f ? v00 : v00 + fx * (v10 - v00);
            const float bottom = fx == 0.0f ? v01 : v01 + fx * (v11 - v01);
            dst[(size_t)gid * nch + ch] = fy == 0.0f ? top : top + fy * (bottom - top);
        }
        return;
    }
    const float4 wx = bake_cubic_weights(fx), wy = bake_cubic_weights(fy);
    const float wxs[4] = {wx.x, wx.y, wx.z, wx.w}, wys[4] = {wy.x, wy.y, wy.z, wy.w};
    int xs[4], ys[4];
    for (int k = 0; k < 4; ++k) {
        xs[k] = bake_index(x0 - 1 + k, w, periodic & 1);
        ys[k] = bake_index(y0 - 1 + k, h, periodic & 2);
    }
    for (int ch = 0; ch < nch; ++ch) {
        if (fx == 0.0f && fy == 0.0f) {
            dst[(size_t)gid * nch + ch] = src[((size_t)ys[1] * w + xs[1]) * nch + ch];
            continue;
        }
        float v = 0.0f;
        for (int b = 0; b < 4; ++b) {
            float row = 0.0f;
            for (int a = 0; a < 4; ++a)
                row += wxs[a] * src[((size_t)ys[b] * w + xs[a]) * nch + ch];
            v += wys[b] * row;
        }
        dst[(size_t)gid * nch + ch] = v;
    }
}
