// SPDX-License-Identifier: Apache-2.0
// Transposes of an R2C half spectrum between the two passes of a 2-D FFT
// (host/fft/fft_plan.cpp): rows x columns complex values <-> columns x rows.
// common.h is prepended by the host.

__kernel void fft_transpose(__global const float2* in, int rows, int columns, __global float2* out)
{
    int c, r, gid = relief_grid_cell(columns, rows, &c, &r);
    if (gid < 0)
        return;
    out[(size_t)c * rows + r] = in[gid];
}

// Where VkFFT plans no real-to-complex transform of the rows' length n0
// (host/fft/fft_plan.cpp), the rows go through a complex transform: widened to
// complex, the half spectrum kept (n0/2 + 1 values a row, the R2C layout),
// and back: the whole Hermitian spectrum rebuilt, its inverse's real part
// taken (the imaginary parts of the DC and Nyquist terms, which a C2R
// ignores, only add imaginary parts there). `stride`: floats a real row.
__kernel void fft_widen(__global const float* in, int n0, int n1, int stride, __global float2* wide)
{
    int i, r, gid = relief_grid_cell(n0, n1, &i, &r);
    if (gid < 0)
        return;
    wide[gid] = (float2)(in[(size_t)r * stride + i], 0.0f);
}

__kernel void fft_narrow(__global const float2* wide, int n0, int n1, __global float2* spectrum)
{
    int columns = n0 / 2 + 1;
    int k, r, gid = relief_grid_cell(columns, n1, &k, &r);
    if (gid < 0)
        return;
    spectrum[gid] = wide[(size_t)r * n0 + k];
}

__kernel void fft_hermitian(__global const float2* spectrum, int n0, int n1, __global float2* wide)
{
    int columns = n0 / 2 + 1;
    int k, r, gid = relief_grid_cell(n0, n1, &k, &r);
    if (gid < 0)
        return;
    if (k < columns) {
        wide[gid] = spectrum[(size_t)r * columns + k];
    } else {
        float2 c = spectrum[(size_t)r * columns + (n0 - k)];
        wide[gid] = (float2)(c.x, -c.y);
    }
}

__kernel void fft_real_part(__global const float2* wide, int n0, int n1, int stride, __global float* out)
{
    int i, r, gid = relief_grid_cell(stride, n1, &i, &r);
    if (gid < 0)
        return;
    out[gid] = i < n0 ? wide[(size_t)r * n0 + i].x : 0.0f;
}
