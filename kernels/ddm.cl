// SPDX-License-Identifier: Apache-2.0
// DDM derivation (docs/design.md §4.1): decoded normal map -> per-texel slopes.
// common.h is prepended by the host.

// One work-item per texel, over the texels [first, first + count): `normals`
// holds their `channels` (2 or 3) floats per texel (the host streams the
// map in chunks); each stored value v decodes to v * scale + bias (UNORM: 2v - 1);
// decoded x and y within zero_band of 0 are exactly 0.
// green_to_row maps the decoded green component to the row component of the
// normal: -1 for OpenGL (green points up the image), +1 for DirectX.
// Grazing normals are clamped to max_angle from +z keeping their azimuth, so
// the slope stays finite and points the same way. Unusable normals (NaN, Inf,
// zero length, or pointing straight down) become flat and are counted.
__kernel void ddm_slopes(__global const float* normals, int channels, int first, int count, float scale,
                         float bias, float zero_band, float green_to_row, float cos_max_angle,
                         float sin_max_angle, __global float2* slopes, __global int* counters)
{
    int k = get_global_id(0);
    if (k >= count)
        return;
    int i = first + k;
    __global const float* v = normals + (size_t)k * channels;
    float nx = v[0] * scale + bias;
    float ny = (v[1] * scale + bias) * green_to_row;
    // Integer maps have no code for 0: the two codes around the midpoint
    // (127 and 128 of 255) both mean "flat", not a tilt of 1/255.
    nx = fabs(nx) <= zero_band ? 0.0f : nx;
    ny = fabs(ny) <= zero_band ? 0.0f : ny;
    float nz;
    if (channels == 2)
        nz = sqrt(fmax(0.0f, 1.0f - nx * nx - ny * ny));
    else
        nz = v[2] * scale + bias;

    float len2 = nx * nx + ny * ny + nz * nz;
    if (!isfinite(len2) || len2 < 1e-12f) {
        slopes[i] = (float2)(0.0f, 0.0f);
        atomic_inc(&counters[0]);
        return;
    }
    float inv = rsqrt(len2);
    nx *= inv;
    ny *= inv;
    nz *= inv;
    if (nz < cos_max_angle) {
        float t = sqrt(nx * nx + ny * ny);
        if (t < 1e-6f) {  // straight down: no azimuth to keep
            slopes[i] = (float2)(0.0f, 0.0f);
            atomic_inc(&counters[0]);
            return;
        }
        nx *= sin_max_angle / t;
        ny *= sin_max_angle / t;
        nz = cos_max_angle;
        atomic_inc(&counters[1]);
    }
    slopes[i] = (float2)(-nx / nz, -ny / nz);
}

// Curl of the slope field under both green conventions, summed per row.
// Cell (x, y) spans the texel centres (x..x+1, y..y+1); its circulation uses
// trapezoidal edge averages:  a = d(gy)/dx,  b = d(gx)/dy.  The slopes were
// derived with the OpenGL convention; flipping to DirectX negates gy, so
// curl_gl = a - b and curl_dx = -a - b. One work-item per row of cells sums
// the squares with compensated summation; the host adds the rows in double.
__kernel void curl_row_sums(__global const float2* slopes, int width, int cell_rows,
                            __global float2* row_sums)
{
    int y = get_global_id(0);
    if (y >= cell_rows)
        return;
    __global const float2* r0 = slopes + (size_t)y * width;
    __global const float2* r1 = r0 + width;
    float s_gl = 0.0f, c_gl = 0.0f, s_dx = 0.0f, c_dx = 0.0f;
    for (int x = 0; x + 1 < width; ++x) {
        float2 g00 = r0[x], g10 = r0[x + 1], g01 = r1[x], g11 = r1[x + 1];
        float a = 0.5f * ((g10.y + g11.y) - (g00.y + g01.y));
        float b = 0.5f * ((g01.x + g11.x) - (g00.x + g10.x));
        float e_gl = (a - b) * (a - b) - c_gl;
        float t_gl = s_gl + e_gl;
        c_gl = (t_gl - s_gl) - e_gl;
        s_gl = t_gl;
        float e_dx = (a + b) * (a + b) - c_dx;
        float t_dx = s_dx + e_dx;
        c_dx = (t_dx - s_dx) - e_dx;
        s_dx = t_dx;
    }
    row_sums[y] = (float2)(s_gl, s_dx);
}

// Negates the row slope: turns an OpenGL-derived field into the DirectX one.
__kernel void flip_row_slope(__global float2* slopes, int texels)
{
    int i = get_global_id(0);
    if (i < texels)
        slopes[i].y = -slopes[i].y;
}
