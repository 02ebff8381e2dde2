// SPDX-License-Identifier: Apache-2.0
// DCT-II and its inverse (DCT-III) by one real FFT of the same size
// (Makhoul, "A fast cosine transform in one and two dimensions", 1980), so
// that the free-boundary solves rely on VkFFT's plain R2C transforms only:
// VkFFT's own DCT crashed or refused to plan at some sizes. common.h is
// prepended by the host; VkFFT does the R2C / C2R between these kernels.
//
// X[k0,k1] = sum_x sum_y x[x,y] cos(pi k0 (2x+1) / 2n0) cos(pi k1 (2y+1) / 2n1)
//
// Reordering v[m] = x[2m] (m < ceil(n/2)), x[2(n-1-m)+1] (the rest) on each
// axis turns it into the DFT V of v:
//   X[k0,k1] = Re(e^{-i(a0+a1)} V[k0,k1] + e^{-i(a0-a1)} V[k0,n1-k1]) / 2,
//   a = pi k / 2n;
// and back: V[k0,k1] = e^{i(a0+a1)} ((X[k0,k1] - X[n0-k0,n1-k1])
//                                    - i (X[n0-k0,k1] + X[k0,n1-k1])),
// with X = 0 at index n. Dense arrays are n0 x n1 floats, row-major; the
// R2C grid has rows of `stride` floats (n0/2 + 1 complex values).

inline int dct_source(int m, int n)
{
    return m < (n + 1) / 2 ? 2 * m : 2 * (n - 1 - m) + 1;
}

// One work-item per float of the padded grid: the padding is set to 0, as
// the transform reads it.
__kernel void dct_reorder(__global const float* x, int n0, int n1, int stride, __global float* v)
{
    int m0, m1, gid = relief_grid_cell(stride, n1, &m0, &m1);
    if (gid < 0)
        return;
    v[gid] = m0 < n0 ? x[dct_source(m1, n1) * n0 + dct_source(m0, n0)] : 0.0f;
}

__kernel void dct_unreorder(__global const float* v, int n0, int n1, int stride, __global float* x)
{
    int m0, m1, gid = relief_grid_cell(n0, n1, &m0, &m1);
    if (gid < 0)
        return;
    x[dct_source(m1, n1) * n0 + dct_source(m0, n0)] = v[m1 * stride + m0];
}

// V[k0,k1] of a real signal from its R2C half spectrum (k0 <= n0/2 stored).
inline float2 dct_spectrum(__global const float2* V, int k0, int k1, int n0, int n1)
{
    k1 = k1 % n1;
    int columns = n0 / 2 + 1;
    if (k0 < columns)
        return V[k1 * columns + k0];
    float2 c = V[((n1 - k1) % n1) * columns + (n0 - k0)];
    return (float2)(c.x, -c.y);
}

// Re((c + i s) * z)
inline float re_rotated(float c, float s, float2 z)
{
    return c * z.x - s * z.y;
}

// The twiddles w0[k] = (cos, sin)(pi k / 2n0), w1 likewise along axis 1
// (host/fft/dct_plan.cpp, from double), combined by the angle-sum rules: a
// table read costs less than a cospi()/sinpi() call.
__kernel void dct_forward_post(__global const float2* V, int n0, int n1, __global float* X,
                               __global const float2* w0, __global const float2* w1)
{
    int k0, k1, gid = relief_grid_cell(n0, n1, &k0, &k1);
    if (gid < 0)
        return;
    // a0 = pi k0 / 2n0, a1 = pi k1 / 2n1
    float2 t0 = w0[k0], t1 = w1[k1];
    float cc = t0.x * t1.x, ss = t0.y * t1.y, sc = t0.y * t1.x, cs = t0.x * t1.y;
    float2 p = dct_spectrum(V, k0, k1, n0, n1);
    float2 q = dct_spectrum(V, k0, n1 - k1, n0, n1);
    // cos(a0 +- a1) = cc -+ ss, sin(a0 +- a1) = sc +- cs
    X[gid] = 0.5f * (re_rotated(cc - ss, -(sc + cs), p) + re_rotated(cc + ss, -(sc - cs), q));
}

inline float dct_coefficient(__global const float* X, int k0, int k1, int n0, int n1)
{
    return k0 < n0 && k1 < n1 ? X[k1 * n0 + k0] : 0.0f;
}

__kernel void dct_inverse_pre(__global const float* X, int n0, int n1, __global float2* V,
                              __global const float2* w0, __global const float2* w1)
{
    int columns = n0 / 2 + 1;
    int k0, k1, gid = relief_grid_cell(columns, n1, &k0, &k1);
    if (gid < 0)
        return;
    int m0 = k0 > 0 ? n0 - k0 : n0, m1 = k1 > 0 ? n1 - k1 : n1;
    float re = dct_coefficient(X, k0, k1, n0, n1) - dct_coefficient(X, m0, m1, n0, n1);
    float im = -(dct_coefficient(X, m0, k1, n0, n1) + dct_coefficient(X, k0, m1, n0, n1));
    // cos, sin of pi k0 / 2n0 + pi k1 / 2n1 (k0 <= n0/2 < n0)
    float2 t0 = w0[k0], t1 = w1[k1];
    float c = t0.x * t1.x - t0.y * t1.y, s = t0.y * t1.x + t0.x * t1.y;
    V[gid] = (float2)(c * re - s * im, s * re + c * im);
}

// Along axis 1 only, for a map periodic along axis 0 and free along axis 1:
// the grid is an R2C grid (rows of `stride` floats) whose rows are reordered
// as above, and the 2-D R2C then gives, for each k0 <= n0/2, the DFT V along
// axis 1 of the reordered column of x's axis-0 spectrum U. Since the
// relation below is linear in V it holds for that complex column as for a
// real one:
//   X[k0,k1] = (e^{-i a1} V[k0,k1] + e^{i a1} V[k0,n1-k1]) / 2,
//   V[k0,k1] = e^{i a1} (X[k0,k1] - i X[k0,n1-k1]),  X = 0 at index n1,
// with X[k0,k1] = sum_y U[k0,y] cos(pi k1 (2y+1) / 2n1). One work-item per
// float of the grid (reorder), of the texels (unreorder), or complex value
// of the half spectrum (n0/2 + 1 a row).
__kernel void dct_axis1_reorder(__global const float* x, int n0, int n1, int stride, __global float* v)
{
    int m0, m1, gid = relief_grid_cell(stride, n1, &m0, &m1);
    if (gid < 0)
        return;
    v[gid] = x[dct_source(m1, n1) * stride + m0];
}

__kernel void dct_axis1_unreorder(__global const float* v, int n0, int n1, int stride, __global float* x)
{
    int m0, m1, gid = relief_grid_cell(n0, n1, &m0, &m1);
    if (gid < 0)
        return;
    x[dct_source(m1, n1) * stride + m0] = v[m1 * stride + m0];
}

// (c + i s) * z
inline float2 rotated(float c, float s, float2 z)
{
    return (float2)(c * z.x - s * z.y, s * z.x + c * z.y);
}

// w0 (unused) and w1 as dct_forward_post's.
__kernel void dct_axis1_forward_post(__global const float2* V, int n0, int n1, __global float2* X,
                                     __global const float2* w0, __global const float2* w1)
{
    int columns = n0 / 2 + 1;
    int k0, k1, gid = relief_grid_cell(columns, n1, &k0, &k1);
    if (gid < 0)
        return;
    float c = w1[k1].x, s = w1[k1].y;
    float2 p = V[gid], q = V[((n1 - k1) % n1) * columns + k0];
    X[gid] = 0.5f * (rotated(c, -s, p) + rotated(c, s, q));
}

__kernel void dct_axis1_inverse_pre(__global const float2* X, int n0, int n1, __global float2* V,
                                    __global const float2* w0, __global const float2* w1)
{
    int columns = n0 / 2 + 1;
    int k0, k1, gid = relief_grid_cell(columns, n1, &k0, &k1);
    if (gid < 0)
        return;
    float2 p = X[gid], q = k1 > 0 ? X[(n1 - k1) * columns + k0] : (float2)(0.0f, 0.0f);
    V[gid] = rotated(w1[k1].x, w1[k1].y, (float2)(p.x + q.y, p.y - q.x));  // p - i q
}
