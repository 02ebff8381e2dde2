// Weighted least-squares integration (DESIGN.md §4.4, masks and confidence
// weights), solved by preconditioned conjugate gradients. common.h is
// prepended by the host; the preconditioner's transforms are VkFFT's.
//
// Unknowns: the height h per texel. Edges join each texel to its right and
// lower neighbour (wrapping under periodic boundaries; none across the edge
// under free ones). Edge e = (p -> q) wants h(q) - h(p) = t_e, the mean of
// the two texels' slopes along it, with weight c_e:
//   w_e = min(w_p, w_q),  c_e = max(w_e, eps),  t_e = (w_e / c_e) * slope
// so an excluded texel (weight 0) is filled smoothly (target 0 at weight
// eps) instead of following its slopes. The normal equations A h = b have
//   (A h)_p = sum over p's edges of c_e (h_p - h_other)
//   b_p     = sum over edges into p of c_e t_e - sum over edges out of p.
// The preconditioner is the unweighted Laplacian (all c_e = 1), inverted
// exactly by a DCT (free) or FFT (periodic).

inline int right_of(int x, int width, int periodic)
{
    return x + 1 < width ? x + 1 : (periodic ? 0 : -1);
}

// Per texel: the weights and targets of its edge to the right (x) and
// below (y).
__kernel void weighted_edges(__global const float2* slopes, __global const float* weight,
                             int width, int height, int periodic, float eps,
                             __global float2* c, __global float2* t)
{
    int p = get_global_id(0);
    if (p >= width * height)
        return;
    int x = p % width, y = p / width;
    float2 cc = (float2)(0.0f), tt = (float2)(0.0f);
    int xr = right_of(x, width, periodic), yd = right_of(y, height, periodic);
    if (xr >= 0 && xr != x) {
        int q = y * width + xr;
        float we = fmin(weight[p], weight[q]);
        cc.x = fmax(we, eps);
        tt.x = we / cc.x * 0.5f * (slopes[p].x + slopes[q].x);
    }
    if (yd >= 0 && yd != y) {
        int q = yd * width + x;
        float we = fmin(weight[p], weight[q]);
        cc.y = fmax(we, eps);
        tt.y = we / cc.y * 0.5f * (slopes[p].y + slopes[q].y);
    }
    c[p] = cc;
    t[p] = tt;
}

inline int left_of(int x, int width, int periodic)
{
    return x > 0 ? x - 1 : (periodic ? width - 1 : -1);
}

__kernel void weighted_rhs(__global const float2* c, __global const float2* t, int width,
                           int height, int periodic, __global float* b)
{
    int p = get_global_id(0);
    if (p >= width * height)
        return;
    int x = p % width, y = p / width;
    float v = -(c[p].x * t[p].x + c[p].y * t[p].y);
    int xl = left_of(x, width, periodic), yu = left_of(y, height, periodic);
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

__kernel void weighted_apply(__global const float* h, __global const float2* c, int width,
                             int height, int periodic, __global float* out)
{
    int p = get_global_id(0);
    if (p >= width * height)
        return;
    int x = p % width, y = p / width;
    float hp = h[p], v = 0.0f;
    int xr = right_of(x, width, periodic), yd = right_of(y, height, periodic);
    int xl = left_of(x, width, periodic), yu = left_of(y, height, periodic);
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

// Partial sums of a.b per work-group of 64 (the host adds them in a fixed
// order, in double: deterministic whatever the device's threads).
__kernel void weighted_dot(__global const float* a, __global const float* b, int n,
                           __global float* partial)
{
    __local float s[64];
    int i = get_global_id(0), l = get_local_id(0);
    s[l] = i < n ? a[i] * b[i] : 0.0f;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int span = 32; span > 0; span >>= 1) {
        if (l < span)
            s[l] += s[l + span];
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0)
        partial[get_group_id(0)] = s[0];
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

// Dense n0 x n1 <-> padded transform grid.
__kernel void weighted_to_grid(__global const float* v, int n0, int n1, int stride,
                               __global float* grid)
{
    int i = get_global_id(0);
    if (i < n0 * n1)
        grid[(i / n0) * stride + i % n0] = v[i];
}

__kernel void weighted_from_grid(__global const float* grid, int n0, int n1, int stride,
                                 __global float* v)
{
    int i = get_global_id(0);
    if (i < n0 * n1)
        v[i] = grid[(i / n0) * stride + i % n0];
}

// Divides a spectrum by the unweighted Laplacian's eigenvalues; the mean
// (eigenvalue 0) is dropped. Periodic: R2C layout, complex; free: DCT-II.
__kernel void weighted_laplace_divide(__global float* grid, int n0, int n1, int periodic)
{
    int columns = periodic ? n0 / 2 + 1 : n0;
    int gid = get_global_id(0);
    if (gid >= columns * n1)
        return;
    int k = gid % columns, l = gid / columns;
    float step = periodic ? 2.0f * M_PI_F : M_PI_F;
    float lambda = (2.0f - 2.0f * cos(step * k / n0)) + (n1 > 1 ? 2.0f - 2.0f * cos(step * l / n1) : 0.0f);
    float scale = lambda > 0.0f ? 1.0f / lambda : 0.0f;
    if (periodic) {
        __global float2* g = (__global float2*)grid;
        g[gid] *= scale;
    } else {
        grid[gid] *= scale;
    }
}
