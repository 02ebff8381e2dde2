// Radial ray integration, fast kernels (DESIGN.md §4.3). common.h is
// prepended by the host. Same answer as rays_reference.cl with rational
// directions, at a cost that does not grow with the radius.
//
// One rational direction (a, b) of period L = |(a, b)| per launch pair:
//   rays_period_sums   per texel q, the sums over one period of the walk
//                      starting at q (S, U0, U1) and over the partial last
//                      period (P0, P1);
//   rays_chain_windows one work-item per chain q0, q0 + (a, b), ...: slides a
//                      window of K periods along the chain, keeping the
//                      polynomial moments that the ray sum needs, and adds
//                      the ray's weighted height sum and weight to `accum`.
// The period table (seg_offset, seg_data) is segment i of the walk from a
// texel centre to the next chain point: texel offset o_i, and
// (extent x, extent y, length l_i, mid-distance tau_i).
//
// Long chains: the moments are running sums along chains of up to 16K
// texels. With RELIEF_FP64 they are kept in double; otherwise in float and
// recomputed from scratch every `reanchor` steps, which bounds the rounding
// a float running sum collects.

#ifdef RELIEF_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double acc_t;
#else
typedef float acc_t;
#endif

inline int inside(int x, int y, int w, int h)
{
    return x >= 0 && x < w && y >= 0 && y < h;
}

inline int texel_index(int x, int y, int w, int h, int periodic)
{
    if (periodic) {
        x = relief_wrap(x, w);
        y = relief_wrap(y, h);
    }
    return y * w + x;
}

__kernel void rays_period_sums(__global const float2* slopes, int width, int height,
                               int periodic, int step_x, int step_y, int segments,
                               __constant int2* seg_offset, __constant float4* seg_data,
                               float partial, __global float4* sums, __global float* partial1)
{
    int gid = get_global_id(0);
    if (gid >= width * height)
        return;
    int x = gid % width, y = gid / width;
    float s = 0.0f, u0 = 0.0f, u1 = 0.0f, p0 = 0.0f, p1 = 0.0f;
    // Under clip a period leaving the image is never used whole; the chain
    // kernel walks such ends itself.
    if (periodic || inside(x + step_x, y + step_y, width, height)) {
        float run = 0.0f, prun = 0.0f;
        for (int i = 0; i < segments; ++i) {
            int2 o = seg_offset[i];
            float4 d = seg_data[i];
            float2 g = slopes[texel_index(x + o.x, y + o.y, width, height, periodic)];
            float c = g.x * d.x + g.y * d.y;
            float u = run + 0.5f * c;
            u0 += d.z * u;
            u1 += d.z * d.w * u;
            run += c;
            // The partial last period: the same walk cut at `partial`.
            float start = d.w - 0.5f * d.z;
            if (start < partial) {
                float len = fmin(d.z, partial - start);
                float cp = c * (len / d.z);
                float up = prun + 0.5f * cp;
                p0 += len * up;
                p1 += len * (start + 0.5f * len) * up;
                prun += cp;
            }
        }
        s = run;
    }
    sums[gid] = (float4)(s, u0, u1, p0);
    partial1[gid] = p1;
}

// Weighted height sum and weight of the walk from chain point qe = p + m*(a, b)
// on, cut at distance `limit` into the period and at the image edge (clip
// only); h is the height at qe relative to p.
inline void end_walk(__global const float2* slopes, int width, int height, int periodic,
                     int qx, int qy, acc_t m_l, acc_t h, float limit, int segments,
                     __constant int2* seg_offset, __constant float4* seg_data,
                     acc_t* a_out, acc_t* w_out)
{
    acc_t a = 0, w = 0;
    for (int i = 0; i < segments; ++i) {
        float4 d = seg_data[i];
        float start = d.w - 0.5f * d.z;
        if (start >= limit)
            break;
        int2 o = seg_offset[i];
        int x = qx + o.x, y = qy + o.y;
        if (!periodic && !inside(x, y, width, height))
            break;
        float2 g = slopes[texel_index(x, y, width, height, periodic)];
        float len = fmin(d.z, limit - start);
        acc_t dh = (acc_t)((g.x * d.x + g.y * d.y) * (len / d.z));
        acc_t weight = (acc_t)len * (m_l + (acc_t)(start + 0.5f * len));
        a += weight * (h + 0.5 * dh);
        w += weight;
        h += dh;
    }
    *a_out += a;
    *w_out += w;
}

typedef struct {
    acc_t s0, s1, s2;  // sum over the window of m^j * S(q_m), j = 0, 1, 2
    acc_t u0, u1;      // ... of U0(q_m) and m * U0(q_m)
    acc_t v0;          // ... of U1(q_m)
    int nonzero;       // window entries with any non-zero sum
    int count;         // K_eff, the whole periods in the window
} Window;

inline int nonzero_sums(float4 f)
{
    return f.x != 0.0f || f.y != 0.0f || f.z != 0.0f;
}

// The window of up to `k_max` whole periods starting at (x, y), summed afresh.
inline Window window_from_scratch(__global const float4* sums, int width, int height,
                                  int periodic, int step_x, int step_y, int x, int y, int k_max)
{
    Window win = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int m = 0; m < k_max; ++m) {
        int qx = x + m * step_x, qy = y + m * step_y;
        if (!periodic && !inside(qx + step_x, qy + step_y, width, height))
            break;
        float4 f = sums[texel_index(qx, qy, width, height, periodic)];
        acc_t mm = (acc_t)m;
        win.s0 += f.x;
        win.s1 += mm * f.x;
        win.s2 += mm * mm * f.x;
        win.u0 += f.y;
        win.u1 += mm * f.y;
        win.v0 += f.z;
        win.nonzero += nonzero_sums(f);
        win.count = m + 1;
    }
    return win;
}

__kernel void rays_chain_windows(__global const float2* slopes, int width, int height,
                                 int periodic, int step_x, int step_y,
                                 __global const int2* chain_start, int chains, int cycle,
                                 int k_whole, float period, float w0, float w1, float pw0,
                                 float pw1, float partial, int segments,
                                 __constant int2* seg_offset, __constant float4* seg_data,
                                 __global const float4* sums, __global const float* partial1,
                                 int reanchor, __global float2* accum)
{
    int id = get_global_id(0);
    if (id >= chains)
        return;
    int x = chain_start[id].x, y = chain_start[id].y;
    const acc_t L = period, K = k_whole;
    // The origin's own first half-segment is not part of its mean.
    const float4 d0 = seg_data[0];
    const float origin_len = fmin(d0.z, partial > 0.0f && k_whole == 0 ? partial : d0.z);

    Window win;
    for (int k = 0;; ++k) {
        if (periodic ? k == cycle : !inside(x, y, width, height))
            break;
        if (k == 0 || (reanchor > 0 && k % reanchor == 0))
            win = window_from_scratch(sums, width, height, periodic, step_x, step_y, x, y,
                                      k_whole);
        const acc_t n = (acc_t)win.count;
        acc_t a = (acc_t)w0 * L * (0.5 * n * (n - 1.0) * win.s0 - 0.5 * (win.s2 + win.s1)) +
                  (acc_t)w1 * ((n - 1.0) * win.s0 - win.s1) + L * win.u1 + win.v0;
        acc_t w = (acc_t)w0 * L * 0.5 * n * (n - 1.0) + (acc_t)w1 * n;

        // The end of the ray past the whole periods.
        const int ex = x + win.count * step_x, ey = y + win.count * step_y;
        const acc_t m_l = n * L;
        if (win.count == k_whole &&
            (periodic || inside(ex + step_x, ey + step_y, width, height))) {
            if (partial > 0.0f) {
                int e = texel_index(ex, ey, width, height, periodic);
                a += win.s0 * (m_l * pw0 + pw1) + m_l * sums[e].w + partial1[e];
                w += m_l * pw0 + pw1;
            }
        } else {
            end_walk(slopes, width, height, periodic, ex, ey, m_l, win.s0,
                     win.count == k_whole ? partial : period + 1.0f, segments, seg_offset,
                     seg_data, &a, &w);
        }
        const int p = y * width + x;
        float2 g = slopes[p];
        acc_t c0 = (g.x * d0.x + g.y * d0.y) * (origin_len / d0.z);
        a -= (acc_t)origin_len * 0.5 * origin_len * 0.5 * c0;
        w -= (acc_t)origin_len * 0.5 * origin_len;
        float2 acc = accum[p];
        accum[p] = (float2)(acc.x + (float)a, acc.y + (float)w);

        // Slide the window one period on: drop m = 0, shift m -> m - 1, and
        // take in the period K - 1 when the chain still has it.
        const float4 f0 = win.count > 0 ? sums[p] : (float4)(0.0f);  // m = 0 is p itself
        const acc_t s0 = win.s0, s1 = win.s1, u0 = win.u0;
        win.s2 = win.s2 - 2.0 * s1 + s0 - f0.x;
        win.s1 = s1 - s0 + f0.x;
        win.s0 = s0 - f0.x;
        win.u1 = win.u1 - u0 + f0.y;
        win.u0 = u0 - f0.y;
        win.v0 -= f0.z;
        win.nonzero -= nonzero_sums(f0);
        win.count -= win.count > 0;
        const int nx = x + k_whole * step_x, ny = y + k_whole * step_y;  // q_{k+K}
        if (k_whole > 0 &&
            (periodic || inside(nx + step_x, ny + step_y, width, height))) {
            const float4 f = sums[texel_index(nx, ny, width, height, periodic)];
            const acc_t m = K - 1.0;
            win.s0 += f.x;
            win.s1 += m * f.x;
            win.s2 += m * m * f.x;
            win.u0 += f.y;
            win.u1 += m * f.y;
            win.v0 += f.z;
            win.nonzero += nonzero_sums(f);
            win.count += 1;
        }
        // A window over flat texels sums to exactly zero, not to the rounding
        // left behind by the texels that slid out.
        if (win.nonzero == 0)
            win.s0 = win.s1 = win.s2 = win.u0 = win.u1 = win.v0 = 0;

        x += step_x;
        y += step_y;
        if (periodic) {
            x = relief_wrap(x, width);
            y = relief_wrap(y, height);
        }
    }
}

// Turns the accumulated (weighted height sum, weight) into the displacement.
__kernel void rays_finish(__global const float2* accum, int count, __global float* out)
{
    int gid = get_global_id(0);
    if (gid >= count)
        return;
    float2 v = accum[gid];
    out[gid] = v.y > 0.0f ? -v.x / v.y : 0.0f;
}
