// Transposes of an R2C half spectrum between the two passes of a 2-D FFT
// (host/fft_plan.cpp): rows x columns complex values <-> columns x rows.
// common.h is prepended by the host.

__kernel void fft_transpose(__global const float2* in, int rows, int columns,
                            __global float2* out)
{
    int gid = get_global_id(0);
    if (gid >= rows * columns)
        return;
    int c = gid % columns, r = gid / columns;
    out[(size_t)c * rows + r] = in[gid];
}
