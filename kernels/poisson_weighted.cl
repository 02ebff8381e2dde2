// Weighted least-squares integration (DESIGN.md §4.4, masks and confidence
// weights), solved by conjugate gradients. common.h is prepended by the
// host; the transforms between these kernels are VkFFT's (R2C, periodic) or
// host/dct_plan's (DCT-II, free).
//
// One problem with the unmasked solve: the same spectral gradient, the
// gradient of the Frankot–Chellappa basis (kernels/poisson.cl), with a
// weight per texel. Minimise
//   sum_p c_p |grad h(p) - t_p|^2,  c_p = max(w_p, eps),  t_p = (w_p / c_p) g_p
// so an excluded texel (weight 0) is filled smoothly (target 0 at weight
// eps) and all weights 1 give exactly the unmasked answer. Substituting
// h = L^{-1/2} u (L the Laplacian, diagonal in the basis) turns the normal
// equations into R* C R u = R* C t with R = grad L^{-1/2}, the Riesz
// transform: its preconditioned form, solved by plain CG in u.
//
// Grids: the transform layout, n0 (fast) x n1, rows of `stride` floats.
// periodic: R2C spectra, n0/2 + 1 complex values per row; R multiplies by
//           i w / |w|, R* by -i w / |w|; the mean and Nyquist terms are 0.
// free:     DCT-II coefficients U[k,l] of u; gx is a sine series in x, held
//           as the DCT of (-1)^x gx read at k' = n0 - k (kernels/poisson.cl).
//           (-1)^x C (-1)^x = C, so the weights apply without the signs.
//           R:  Yx[n0-k, l] = -(wk/|w|) U[k,l],  Yy[k, n1-l] = -(wl/|w|) U[k,l]
//           R*: U[k,l] = -(wk/|w|) Yx[n0-k, l] - (wl/|w|) Yy[k, n1-l]
//           (the DCT's row scaling cancels: k and n0 - k are both >= 1).

// Per texel: the weight and the (weighted) target slope along the grid's
// axes (swapped when the texture is solved transposed).
__kernel void weighted_targets(__global const float2* slopes, __global const float* weight,
                               int n, int transposed, float eps, __global float* c,
                               __global float2* t)
{
    int p = get_global_id(0);
    if (p >= n)
        return;
    float w = weight[p], cp = fmax(w, eps);
    float2 g = slopes[p];
    c[p] = cp;
    t[p] = (w / cp) * (transposed ? (float2)(g.y, g.x) : g);
}

// gx, gy grids of c * t, with the free boundary's (-1)^x and (-1)^y.
__kernel void weighted_load_targets(__global const float* c, __global const float2* t, int n0,
                                    int n1, int stride, int alternate, __global float* gx,
                                    __global float* gy)
{
    int p = get_global_id(0);
    if (p >= n0 * n1)
        return;
    int i = p % n0, j = p / n0;
    float2 v = c[p] * t[p];
    if (alternate) {
        v.x = (i & 1) ? -v.x : v.x;
        v.y = (j & 1) ? -v.y : v.y;
    }
    gx[j * stride + i] = v.x;
    gy[j * stride + i] = v.y;
}

// In place on the gx and gy grids (real space): times c.
__kernel void weighted_scale(__global float* gx, __global float* gy, __global const float* c,
                             int n0, int n1, int stride)
{
    int p = get_global_id(0);
    if (p >= n0 * n1)
        return;
    int g = (p / n0) * stride + p % n0;
    gx[g] *= c[p];
    gy[g] *= c[p];
}

// Angular frequencies of bin (k, l); periodic bins are R2C (k <= n0/2).
inline float2 bin_omega(int k, int l, int n0, int n1, int periodic)
{
    if (!periodic)
        return (float2)(M_PI_F * k / n0, M_PI_F * l / n1);
    int sl = l < (n1 + 1) / 2 ? l : l - n1;
    return (float2)(2.0f * M_PI_F * k / n0, 2.0f * M_PI_F * sl / n1);
}

inline int periodic_dropped(int k, int l, int n0, int n1)
{
    return (k == 0 && l == 0) || 2 * k == n0 || (n1 > 1 && 2 * l == n1);
}

// R: the spectrum of u to the spectra of gx and gy.
__kernel void weighted_riesz(__global const float* u, int n0, int n1, int periodic,
                             __global float* gx, __global float* gy)
{
    int gid = get_global_id(0);
    if (periodic) {
        int columns = n0 / 2 + 1;
        if (gid >= columns * n1)
            return;
        int k = gid % columns, l = gid / columns;
        __global const float2* U = (__global const float2*)u;
        __global float2* X = (__global float2*)gx;
        __global float2* Y = (__global float2*)gy;
        if (periodic_dropped(k, l, n0, n1)) {
            X[gid] = Y[gid] = (float2)(0.0f);
            return;
        }
        float2 w = bin_omega(k, l, n0, n1, 1);
        w /= length(w);
        float2 z = U[gid];
        float2 iz = (float2)(-z.y, z.x);
        X[gid] = w.x * iz;
        Y[gid] = w.y * iz;
        return;
    }
    if (gid >= n0 * n1)
        return;
    int k = gid % n0, l = gid / n0;
    // Written at the mirrored positions the coefficients are read from.
    float vx = 0.0f, vy = 0.0f;
    if (k > 0) {  // Yx[k, l] = -(w_k'/|w|) U[k', l], k' = n0 - k
        int kk = n0 - k;
        float2 w = bin_omega(kk, l, n0, n1, 0);
        vx = -w.x / length(w) * u[l * n0 + kk];
    }
    if (l > 0) {
        int ll = n1 - l;
        float2 w = bin_omega(k, ll, n0, n1, 0);
        vy = -w.y / length(w) * u[ll * n0 + k];
    }
    gx[gid] = vx;
    gy[gid] = vy;
}

// R*: the spectra of gx and gy to that of u (out of place).
__kernel void weighted_riesz_adjoint(__global const float* gx, __global const float* gy, int n0,
                                     int n1, int periodic, __global float* u)
{
    int gid = get_global_id(0);
    if (periodic) {
        int columns = n0 / 2 + 1;
        if (gid >= columns * n1)
            return;
        int k = gid % columns, l = gid / columns;
        __global const float2* X = (__global const float2*)gx;
        __global const float2* Y = (__global const float2*)gy;
        __global float2* U = (__global float2*)u;
        if (periodic_dropped(k, l, n0, n1)) {
            U[gid] = (float2)(0.0f);
            return;
        }
        float2 w = bin_omega(k, l, n0, n1, 1);
        w /= length(w);
        float2 s = w.x * X[gid] + w.y * Y[gid];
        U[gid] = (float2)(s.y, -s.x);  // -i s
        return;
    }
    if (gid >= n0 * n1)
        return;
    int k = gid % n0, l = gid / n0;
    float2 w = bin_omega(k, l, n0, n1, 0);
    float norm = length(w);
    float v = 0.0f;
    if (norm > 0.0f) {
        if (k > 0)
            v -= w.x / norm * gx[l * n0 + (n0 - k)];
        if (l > 0)
            v -= w.y / norm * gy[(n1 - l) * n0 + k];
    }
    u[gid] = v;
}

// h = L^{-1/2} u in the spectrum, in place: divided by |w|.
__kernel void weighted_unriesz(__global float* u, int n0, int n1, int periodic)
{
    int gid = get_global_id(0);
    if (periodic) {
        int columns = n0 / 2 + 1;
        if (gid >= columns * n1)
            return;
        int k = gid % columns, l = gid / columns;
        __global float2* U = (__global float2*)u;
        U[gid] = periodic_dropped(k, l, n0, n1)
                     ? (float2)(0.0f)
                     : U[gid] / length(bin_omega(k, l, n0, n1, 1));
        return;
    }
    if (gid >= n0 * n1)
        return;
    int k = gid % n0, l = gid / n0;
    u[gid] = gid == 0 ? 0.0f : u[gid] / length(bin_omega(k, l, n0, n1, 0));
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
