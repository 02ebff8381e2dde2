// SPDX-License-Identifier: Apache-2.0
// Least-squares (Poisson) integration by Frankot–Chellappa projection
// (docs/design.md §4.4). common.h is prepended by the host; host/fft_plan (R2C)
// and host/dct_plan (DCT-II) do the transforms between these kernels.
//
// The solve works on an n0 x n1 grid: the texture itself, or its transpose
// when the texture is one texel wide (so that a 1-D texture is always a 1-D
// transform along axis 0).
//
// periodic: h = sum of exp(i w.x); slopes in the same basis; per frequency
//           H = -i (wx Gx + wy Gy) / |w|^2.
// free:     h = sum of a_kl cos(wk (x+1/2)) cos(wl (y+1/2)), wk = pi k / n0
//           (the even extension across the edges: zero normal slope there).
//           gx is then a sine series in x: its coefficients are a DCT-II of
//           (-1)^x gx read at k' = n0 - k, since
//           sin(wk (x+1/2)) = (-1)^x cos(w_{n0-k} (x+1/2)).
//           a_kl = -(wk Bkl + wl Ckl) / (wk^2 + wl^2).
// mixed:    periodic along axis 0, free along axis 1 (the grid is transposed
//           when the map is periodic along y and free along x):
//           h = sum of a_kl exp(i wk x) cos(wl (y+1/2)), wk = 2 pi k / n0,
//           wl = pi l / n1; gx is in the same basis, gy a sine series in y
//           read as above; a_kl = (-i wk Gkl - wl Ckl) / (wk^2 + wl^2).
// Nyquist terms (a derivative with no sign) and the mean are dropped.
// highpass: the solution is multiplied by 1 - exp(-|w|^2 sigma^2 / 2), i.e.
// a Gaussian blur of itself is subtracted.

inline float2 texel_slope(__global const float2* slopes, int width, int i, int j, int transposed)
{
    // Axis 0 of the grid is x, or y when transposed.
    float2 g = transposed ? slopes[i * width + j] : slopes[j * width + i];
    return transposed ? (float2)(g.y, g.x) : g;
}

// One work-item per float of the n1 rows of `stride` floats: the padding
// past n0 (the R2C rows' last one or two) is set to 0, as the transform
// reads it.
__kernel void poisson_split(__global const float2* slopes, int width, int n0, int n1, int transposed,
                            int stride, int alternate0, int alternate1, __global float* gx,
                            __global float* gy)
{
    int i, j, gid = relief_grid_cell(stride, n1, &i, &j);
    if (gid < 0)
        return;
    if (i >= n0) {
        gx[gid] = 0.0f;
        gy[gid] = 0.0f;
        return;
    }
    float2 g = texel_slope(slopes, width, i, j, transposed);
    // a free axis: the (-1)^x or (-1)^y of the sine series along it
    if (alternate0 && (i & 1))
        g.x = -g.x;
    if (alternate1 && (j & 1))
        g.y = -g.y;
    gx[j * stride + i] = g.x;
    gy[j * stride + i] = g.y;
}

inline float highpass_gain(float w2, float sigma)
{
    return sigma > 0.0f ? -expm1(-0.5f * w2 * sigma * sigma) : 1.0f;
}

// In place on gx's spectrum: n0/2 + 1 complex values per row.
__kernel void poisson_periodic_divide(__global float2* gx, __global const float2* gy, int n0, int n1,
                                      float sigma)
{
    int columns = n0 / 2 + 1;
    int kx, ky, gid = relief_grid_cell(columns, n1, &kx, &ky);
    if (gid < 0)
        return;
    int sy = ky < (n1 + 1) / 2 ? ky : ky - n1;  // signed frequency
    int nyquist = (2 * kx == n0) || (n1 > 1 && 2 * ky == n1);
    float wx = 2.0f * M_PI_F * kx / n0, wy = 2.0f * M_PI_F * sy / n1;
    float w2 = wx * wx + wy * wy;
    if (nyquist || w2 == 0.0f) {
        gx[gid] = (float2)(0.0f, 0.0f);
        return;
    }
    float2 a = gx[gid], b = gy[gid];
    // s = wx Gx + wy Gy;  H = -i s / |w|^2 = (s.im, -s.re) / |w|^2
    float2 s = wx * a + wy * b;
    float scale = highpass_gain(w2, sigma) / w2;
    gx[gid] = (float2)(s.y * scale, -s.x * scale);
}

inline float free_coefficient(float b, float c, int k, int l, int n0, int n1, float sigma)
{
    float wk = M_PI_F * k / n0, wl = M_PI_F * l / n1;
    float w2 = wk * wk + wl * wl;
    return w2 > 0.0f ? -(wk * b + wl * c) * highpass_gain(w2, sigma) / w2 : 0.0f;
}

// In place on dx: a_kl needs dx at (n0 - k, l), so one work item solves the
// pair k and n0 - k (k = 0 reads nothing from dx).
__kernel void poisson_free_divide(__global float* dx, __global const float* dy, int n0, int n1, float sigma)
{
    int pairs = n0 / 2 + 1;
    int k, l, gid = relief_grid_cell(pairs, n1, &k, &l);
    if (gid < 0)
        return;
    float c = l > 0 ? dy[(n1 - l) * n0 + k] : 0.0f;
    if (k == 0) {
        dx[l * n0] = free_coefficient(0.0f, c, 0, l, n0, n1, sigma);
        return;
    }
    int m = n0 - k;  // the partner; m == k when n0 is even and k = n0/2
    float b = dx[l * n0 + m], bm = dx[l * n0 + k];
    float cm = l > 0 ? dy[(n1 - l) * n0 + m] : 0.0f;
    dx[l * n0 + k] = free_coefficient(b, c, k, l, n0, n1, sigma);
    if (m != k)
        dx[l * n0 + m] = free_coefficient(bm, cm, m, l, n0, n1, sigma);
}

// In place on gx's spectrum from host/dct_plan's DctPlan along axis 1: n0/2 + 1
// complex values per row; gy's sine coefficient of row l is its cosine
// coefficient of row n1 - l.
__kernel void poisson_mixed_divide(__global float2* gx, __global const float2* gy, int n0, int n1,
                                   float sigma)
{
    int columns = n0 / 2 + 1;
    int k, l, gid = relief_grid_cell(columns, n1, &k, &l);
    if (gid < 0)
        return;
    float wk = 2.0f * M_PI_F * k / n0, wl = M_PI_F * l / n1;
    float w2 = wk * wk + wl * wl;
    if (2 * k == n0 || w2 == 0.0f) {
        gx[gid] = (float2)(0.0f, 0.0f);
        return;
    }
    float2 g = gx[gid], c = l > 0 ? gy[(n1 - l) * columns + k] : (float2)(0.0f, 0.0f);
    float scale = highpass_gain(w2, sigma) / w2;
    // -i wk g - wl c
    gx[gid] = (float2)(wk * g.y - wl * c.x, -wk * g.x - wl * c.y) * scale;
}

__kernel void poisson_gather(__global const float* grid, int stride, int n0, int n1, int width,
                             int transposed, __global float* height)
{
    int i, j, gid = relief_grid_cell(n0, n1, &i, &j);
    if (gid < 0)
        return;
    float v = grid[j * stride + i];
    if (transposed)
        height[i * width + j] = v;
    else
        height[j * width + i] = v;
}
