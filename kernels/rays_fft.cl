// SPDX-License-Identifier: Apache-2.0
// Radial ray integration of periodic textures as one convolution (docs/design.md
// §4.3, periodic boundaries). common.h is prepended by the host.
//
// A texel's weighted ray sum A(p) is linear in the slopes and, on a torus,
// the same combination of offsets for every p:
//   A(p) = sum over q of Kx(q - p) gx(q) + Ky(q - p) gy(q),
// where segment s of a ray adds its extent times (its own weight / 2 + the
// weights of all later segments) to K at its texel offset. The host builds
// the kernels from the same walk tables as the reference kernel (so the
// answer is the same to rounding), VkFFT transforms them and the slopes,
// and these kernels combine the spectra: H = -(Gx Kx* + Gy Ky*) / W, where
// W is the total weight and Kx* the spectrum of the mirrored kernel. The
// two kernel grids are made one after the other in one buffer (the host
// scatters each one's few non-zero taps), so the product is taken in two
// steps: Gx Kx*, then (that + Gy Ky*) / -W.

// One kernel's non-zero taps into a zeroed grid (the indices are distinct).
__kernel void rays_fft_scatter(__global float* grid, __global const int* index, __global const float* value,
                               int count)
{
    int i = get_global_id(0);
    if (i < count)
        grid[index[i]] = value[i];
}

// g *= k, complex, in place.
__kernel void rays_fft_multiply(__global float2* g, __global const float2* k, int count)
{
    int i = get_global_id(0);
    if (i >= count)
        return;
    float2 a = g[i], u = k[i];
    g[i] = (float2)(a.x * u.x - a.y * u.y, a.x * u.y + a.y * u.x);
}

// g = (g + h k) * scale, complex, in place.
__kernel void rays_fft_multiply_add(__global float2* g, __global const float2* h, __global const float2* k,
                                    int count, float scale)
{
    int i = get_global_id(0);
    if (i >= count)
        return;
    float2 a = g[i], b = h[i], v = k[i];
    float re = a.x + b.x * v.x - b.y * v.y;
    float im = a.y + b.x * v.y + b.y * v.x;
    g[i] = (float2)(re * scale, im * scale);
}
