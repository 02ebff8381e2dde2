// SPDX-License-Identifier: Apache-2.0
// Weighted least-squares integration (docs/design.md §4.4, masks and confidence
// weights), solved by preconditioned conjugate gradients. common.h is
// prepended by the host; the preconditioner's transforms are host/fft_plan's
// (periodic) and host/dct_plan's (free).
//
// Unknowns: the height h per texel. Edges join each texel to its right and
// lower neighbour (wrapping along a periodic axis; none across the edge of a
// free one). Edge e = (p -> q) wants h(q) - h(p) = t_e with weight
//   c_e = max(min(w_p, w_q), eps).
// One problem with the unmasked (spectral, Frankot–Chellappa) solve: the
// targets are
//   t_e = mean of (s g) over p, q  +  delta(q) - delta(p),
//   s = w / max(w, eps) per texel (0 for an excluded texel, 1 from eps up),
//   delta = FC(s g) - L^-1 D^T mean(s g)
// (the spectral solution minus the discrete one of the same slopes). With
// all weights 1 the discrete solution is then FC(g) exactly, and it moves
// continuously with the weights; an excluded texel's slopes are not used
// and its hole is filled smoothly (weight eps). The normal equations A h = b:
//   (A h)_p = sum over p's edges of c_e (h_p - h_other)
//   b_p     = sum over edges into p of c_e t_e - sum over edges out of p.
// The preconditioner is the unweighted Laplacian (all c_e = 1), inverted
// exactly by the transform the boundaries take: FFT along a periodic axis,
// DCT along a free one.

// s g per texel: the slopes an excluded texel contributes are 0.
__kernel void weighted_mask_slopes(__global const float2* slopes, __global const float* weight, int n,
                                   float eps, __global float2* out)
{
    int p = get_global_id(0);
    if (p >= n)
        return;
    float w = weight[p];
    out[p] = (w / fmax(w, eps)) * slopes[p];
}

inline int right_of(int x, int width, int periodic)
{
    return x + 1 < width ? x + 1 : (periodic ? 0 : -1);
}

// Per texel: the weights and targets of its edge to the right (x) and
// below (y), from the masked slopes sg. unit: all weights 1 and no delta
// (the discrete solve of mean(s g) that delta needs).
__kernel void weighted_edges(__global const float2* sg, __global const float* weight,
                             __global const float* delta, int width, int height, int periodic_x,
                             int periodic_y, float eps, int unit, __global float2* c, __global float2* t)
{
    int x, y, p = relief_grid_cell(width, height, &x, &y);
    if (p < 0)
        return;
    float2 cc = (float2)(0.0f), tt = (float2)(0.0f);
    int xr = right_of(x, width, periodic_x), yd = right_of(y, height, periodic_y);
    if (xr >= 0 && xr != x) {
        int q = y * width + xr;
        cc.x = unit ? 1.0f : fmax(fmin(weight[p], weight[q]), eps);
        tt.x = 0.5f * (sg[p].x + sg[q].x) + (unit ? 0.0f : delta[q] - delta[p]);
    }
    if (yd >= 0 && yd != y) {
        int q = yd * width + x;
        cc.y = unit ? 1.0f : fmax(fmin(weight[p], weight[q]), eps);
        tt.y = 0.5f * (sg[p].y + sg[q].y) + (unit ? 0.0f : delta[q] - delta[p]);
    }
    c[p] = cc;
    t[p] = tt;
}

inline int left_of(int x, int width, int periodic)
{
    return x > 0 ? x - 1 : (periodic ? width - 1 : -1);
}

__kernel void weighted_rhs(__global const float2* c, __global const float2* t, int width, int height,
                           int periodic_x, int periodic_y, __global float* b)
{
    int x, y, p = relief_grid_cell(width, height, &x, &y);
    if (p < 0)
        return;
    float v = -(c[p].x * t[p].x + c[p].y * t[p].y);
    int xl = left_of(x, width, periodic_x), yu = left_of(y, height, periodic_y);
    if (xl >= 0 && xl != x) {
        int q = y * width + xl;
        v += c[q].x * t[q].x;
    }
    if (yu >= 0 && yu != y) {
        int q = yu * width + x;
        v += c[q].y * t[q].y;
    }
    b[p] = v;
}

__kernel void weighted_apply(__global const float* h, __global const float2* c, int width, int height,
                             int periodic_x, int periodic_y, __global float* out)
{
    int x, y, p = relief_grid_cell(width, height, &x, &y);
    if (p < 0)
        return;
    float hp = h[p], v = 0.0f;
    int xr = right_of(x, width, periodic_x), yd = right_of(y, height, periodic_y);
    int xl = left_of(x, width, periodic_x), yu = left_of(y, height, periodic_y);
    if (xr >= 0 && xr != x)
        v += c[p].x * (hp - h[y * width + xr]);
    if (yd >= 0 && yd != y)
        v += c[p].y * (hp - h[yd * width + x]);
    if (xl >= 0 && xl != x)
        v += c[y * width + xl].x * (hp - h[y * width + xl]);
    if (yu >= 0 && yu != y)
        v += c[yu * width + x].y * (hp - h[yu * width + x]);
    out[p] = v;
}

// Partial sums of a.b per work-group, whose size is a power of two that the
// host chose from the device's limits, with `s` one float per work-item
// (the host adds the partials in a fixed order, in double: deterministic
// whatever the device's threads).
RELIEF_DEFINE_GROUP_SUM(weighted_group_sum, float)

__kernel void weighted_dot(__global const float* a, __global const float* b, int n, __global float* partial,
                           __local float* s)
{
    int i = get_global_id(0);
    weighted_group_sum(i < n ? a[i] * b[i] : 0.0f, s, partial);
}

// y = y + alpha * x
__kernel void weighted_axpy(__global float* y, __global const float* x, float alpha, int n)
{
    int i = get_global_id(0);
    if (i < n)
        y[i] += alpha * x[i];
}

// p = z + beta * p
__kernel void weighted_xpby(__global float* p, __global const float* z, float beta, int n)
{
    int i = get_global_id(0);
    if (i < n)
        p[i] = z[i] + beta * p[i];
}

// Dense texture <-> padded n0 x n1 transform grid, whose axis 0 is the
// texture's x, or its y when `transposed` (the grid is then the texture's
// transpose: n0 = its height). to_grid has one work-item per float of the
// grid and sets the padding to 0, as the transform reads it.
__kernel void weighted_to_grid(__global const float* v, int n0, int n1, int stride, int transposed,
                               __global float* grid)
{
    int i, j, g = relief_grid_cell(stride, n1, &i, &j);
    if (g < 0)
        return;
    grid[g] = i < n0 ? v[transposed ? i * n1 + j : j * n0 + i] : 0.0f;
}

__kernel void weighted_from_grid(__global const float* grid, int n0, int n1, int stride, int transposed,
                                 __global float* v)
{
    int t = get_global_id(0);
    if (t >= n0 * n1)
        return;
    // texel t: grid cell (i, j) = (t % n0, t / n0), or (t / n1, t % n1) transposed
    v[t] = transposed ? grid[(t % n1) * stride + t / n1] : grid[(t / n0) * stride + t % n0];
}

// Divides a spectrum by the unweighted Laplacian's eigenvalues
// 4 sin^2(w/2) per axis (not 2 - 2 cos w: in float that is 0 for the lowest
// mode of a 16384-texel axis); the mean (eigenvalue 0) is dropped.
// Periodic axis 0: R2C layout, complex (the FFT, or the FFT along axis 0
// with the DCT-II along a free axis 1); free axis 0: the 2-D DCT-II, real.
__kernel void weighted_laplace_divide(__global float* grid, int n0, int n1, int periodic0, int periodic1)
{
    int columns = periodic0 ? n0 / 2 + 1 : n0;
    int k, l, gid = relief_grid_cell(columns, n1, &k, &l);
    if (gid < 0)
        return;
    // Half angles in units of pi: w/2 = pi k / n0 (periodic), pi k / 2n0 (free).
    float hk = periodic0 ? (float)k / n0 : (float)k / (2.0f * n0);
    float hl = periodic1 ? (float)l / n1 : (float)l / (2.0f * n1);
    float sk = sinpi(hk), sl = n1 > 1 ? sinpi(hl) : 0.0f;
    float lambda = 4.0f * (sk * sk + sl * sl);
    float scale = lambda > 0.0f ? 1.0f / lambda : 0.0f;
    if (periodic0) {
        __global float2* g = (__global float2*)grid;
        g[gid] *= scale;
    } else {
        grid[gid] *= scale;
    }
}
