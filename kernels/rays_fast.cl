// SPDX-License-Identifier: Apache-2.0
// Radial ray integration, fast kernels (docs/design.md §4.3). common.h is
// prepended by the host. Same answer as rays_reference.cl with rational
// directions, at a cost that does not grow with the radius.
//
// One rational direction (a, b) of period L = |(a, b)| per launch pair:
//   rays_period_sums   per texel q, the sums over one period of the walk
//                      starting at q (S, U0, U1), over the partial last
//                      period (P0, P1), and q's own first half-segment's term;
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

typedef relief_acc_t acc_t;  // (common.h)

inline int inside(int x, int y, int w, int h)
{
    return x >= 0 && x < w && y >= 0 && y < h;
}

inline int in_rect(int x, int y, int4 r)
{
    return x >= r.x && x <= r.z && y >= r.y && y <= r.w;
}

inline int texel_index(int x, int y, int w, int h, int periodic)
{
    if (periodic) {
        x = relief_wrap(x, w);
        y = relief_wrap(y, h);
    }
    return y * w + x;
}

// seg_cut[i] = (l'_i, l'_i / l_i, l'_i * tau'_i, 0): segment i cut at
// `partial` (l' = 0 past it); seg_linear[i] = o_i.y * width + o_i.x.
__kernel void rays_period_sums(__global const float2* slopes, int width, int height, int periodic, int step_x,
                               int step_y, int segments, __constant int2* seg_offset,
                               __constant float4* seg_data, __constant float4* seg_cut,
                               __constant int* seg_linear, float origin_len, __global const uchar* active,
                               int tile, int tiles_x, int4 unused, __global float4* sums,
                               __global float2* tail)
{
    // Under clip, the texels whose rays all stay in the image come from the
    // FFT, and the sums of q serve only the chain points q - m (a, b),
    // m = 0..K: `unused` (inclusive; empty when x0 > x1) holds the q for
    // which none of them is walked. The launch covers the rest: the rows
    // above and below it, and the texels left and right of it.
    int gid = get_global_id(0), x, y;
    if (unused.x <= unused.z && unused.y <= unused.w) {
        const int top = unused.y * width, gap = unused.z - unused.x + 1, side = width - gap;
        const int middle = (unused.w - unused.y + 1) * side;
        if (gid < top) {
            x = gid % width;
            y = gid / width;
        } else if (gid < top + middle) {
            const int k = gid - top, c = k % side;
            y = unused.y + k / side;
            x = c < unused.x ? c : c + gap;
        } else {
            const int k = gid - top - middle;
            y = unused.w + 1 + k / width;
            x = k % width;
        }
        if (y >= height)
            return;
        gid = y * width + x;
    } else {
        if (gid >= width * height)
            return;
        x = gid % width;
        y = gid / width;
    }
    if (!active[(y / tile) * tiles_x + x / tile]) {  // all zero slopes within reach
        sums[gid] = (float4)(0.0f);
        tail[gid] = (float2)(0.0f);
        return;
    }
    float s = 0.0f, u0 = 0.0f, u1 = 0.0f, p0 = 0.0f, p1 = 0.0f;
    // The origin's own first half-segment (length origin_len = min(l_0, R))
    // is not part of its own mean; its term is subtracted by the chain kernel.
    const float4 d0 = seg_data[0];
    const float2 g0 = slopes[gid];
    const float c0 = (g0.x * d0.x + g0.y * d0.y) * (origin_len / d0.z);
    const float origin = 0.25f * origin_len * origin_len * c0;
    // The period's texels lie in the box from q to q + (a, b).
    const int interior = x + min(0, step_x) >= 0 && x + max(0, step_x) < width && y + min(0, step_y) >= 0 &&
                         y + max(0, step_y) < height;
    // Under clip a period leaving the image is never used whole; the chain
    // kernel walks such ends itself.
    if (interior || periodic) {
        float run = 0.0f, prun = 0.0f;
        for (int i = 0; i < segments; ++i) {
            float2 g;
            if (interior) {  // most texels: no wrapping, no branches
                g = slopes[gid + seg_linear[i]];
            } else {
                int2 o = seg_offset[i];
                g = slopes[texel_index(x + o.x, y + o.y, width, height, 1)];
            }
            const float4 d = seg_data[i];
            const float4 cut = seg_cut[i];
            const float c = g.x * d.x + g.y * d.y;
            const float u = run + 0.5f * c;
            u0 += d.z * u;
            u1 += d.z * d.w * u;
            run += c;
            // The partial last period: the same walk cut at `partial`.
            const float cp = c * cut.y;
            const float up = prun + 0.5f * cp;
            p0 += cut.x * up;
            p1 += cut.z * up;
            prun += cp;
        }
        s = run;
    }
    sums[gid] = (float4)(s, u0, u1, p0);
    tail[gid] = (float2)(p1, origin);
}

// Weighted height sum and weight of the walk from chain point qe = p + m*(a, b)
// on, cut at distance `limit` into the period and at the image edge (clip
// only); h is the height at qe relative to p.
inline void end_walk(__global const float2* slopes, int width, int height, int periodic, int qx, int qy,
                     acc_t m_l, acc_t h, float limit, int segments, __constant int2* seg_offset,
                     __constant float4* seg_data, acc_t* a_out, acc_t* w_out)
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

// Adds texel sums f as the window's m-th term.
inline void window_add(Window* win, float4 f, acc_t m)
{
    win->s0 += f.x;
    win->s1 += m * f.x;
    win->s2 += m * m * f.x;
    win->u0 += f.y;
    win->u1 += m * f.y;
    win->v0 += f.z;
    win->nonzero += nonzero_sums(f);
}

// The window of up to `k_max` whole periods starting at (x, y), summed afresh.
inline Window window_from_scratch(__global const float4* sums, int width, int height, int periodic,
                                  int step_x, int step_y, int x, int y, int k_max)
{
    Window win = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int m = 0; m < k_max; ++m) {
        int qx = x + m * step_x, qy = y + m * step_y;
        if (!periodic && !inside(qx + step_x, qy + step_y, width, height))
            break;
        float4 f = sums[texel_index(qx, qy, width, height, periodic)];
        window_add(&win, f, (acc_t)m);
        win.count = m + 1;
    }
    return win;
}

// The state of one chain walk.
typedef struct {
    Window win;
    int x, y;    // p = q_k
    int nx, ny;  // q_{k+K}, kept wrapped
    int k;
    int done;
    int rebuild;  // the window starts afresh here (after a jump over fft_rect)
} Chain;

typedef struct {
    __global const float2* slopes;
    int width, height, periodic, step_x, step_y, cycle, k_whole;
    float period, w0, w1, pw0, pw1, partial;
    int segments;
    __constant int2* seg_offset;
    __constant float4* seg_data;
    __global const float4* sums;
    __global const float2* tail;
    int reanchor;
    __global float2* accum;
    __global const uchar* active;
    int tile, tiles_x;
    acc_t origin_w;
    float dir_weight;  // the direction's angular quadrature weight
    int4 fft_rect;     // clip: texels the FFT gives (inclusive; empty when x0 > x1)
} ChainArgs;

inline void chain_begin(Chain* c, int2 start, const ChainArgs* g)
{
    c->x = start.x;
    c->y = start.y;
    c->nx = start.x + g->k_whole * g->step_x;
    c->ny = start.y + g->k_whole * g->step_y;
    if (g->periodic) {
        c->nx = relief_wrap(c->nx, g->width);
        c->ny = relief_wrap(c->ny, g->height);
    }
    c->k = 0;
    c->done = 0;
    c->rebuild = 0;
}

// Steps along (sx, sy) from (x, y), inside r, to the first point past r.
inline int steps_out_of(int x, int y, int sx, int sy, int4 r)
{
    int s = INT_MAX;
    if (sx > 0)
        s = min(s, (r.z - x) / sx + 1);
    else if (sx < 0)
        s = min(s, (x - r.x) / -sx + 1);
    if (sy > 0)
        s = min(s, (r.w - y) / sy + 1);
    else if (sy < 0)
        s = min(s, (y - r.y) / -sy + 1);
    return s;
}

// Adds the ray sum of chain point q_k to accum and slides the window on.
inline void chain_step(Chain* c, const ChainArgs* g)
{
    const int width = g->width, height = g->height, periodic = g->periodic;
    const int step_x = g->step_x, step_y = g->step_y, k_whole = g->k_whole;
    const float partial = g->partial;
    if (periodic ? c->k == g->cycle : !inside(c->x, c->y, width, height)) {
        c->done = 1;
        return;
    }
    if (!periodic && in_rect(c->x, c->y, g->fft_rect)) {
        // The chain's run through the FFT's rectangle (one run: it is
        // convex) is skipped; the window starts afresh past it (it only
        // looks ahead, so that is exact).
        const int jump = steps_out_of(c->x, c->y, step_x, step_y, g->fft_rect);
        c->x += jump * step_x;
        c->y += jump * step_y;
        c->nx += jump * step_x;
        c->ny += jump * step_y;
        c->k += jump;
        c->rebuild = 1;
        return;
    }
    const int x = c->x, y = c->y;
    Window win = c->win;
    if (c->k == 0 || c->rebuild || (g->reanchor > 0 && c->k % g->reanchor == 0))
        win = window_from_scratch(g->sums, width, height, periodic, step_x, step_y, x, y, k_whole);
    c->rebuild = 0;
    const acc_t L = g->period, K = k_whole;
    const acc_t n = (acc_t)win.count;
    const int p = y * width + x;
    // Texels of inactive tiles have only zero slopes within reach: skipped.
    const int active = g->active[(y / g->tile) * g->tiles_x + x / g->tile];

    // The end of the ray past the whole periods.
    const int whole = win.count == k_whole;
    const int ex = whole ? c->nx : x + win.count * step_x;
    const int ey = whole ? c->ny : y + win.count * step_y;
    // q_{k+K}'s sums: the partial last period here, the window's next entry below.
    float4 next = (float4)(0.0f);
    const int next_whole = whole && (periodic || inside(ex + step_x, ey + step_y, width, height));
    const int e = ey * width + ex;
    if (next_whole)
        next = g->sums[e];
    if (active) {
        acc_t a = (acc_t)g->w0 * L * (0.5 * n * (n - 1.0) * win.s0 - 0.5 * (win.s2 + win.s1)) +
                  (acc_t)g->w1 * ((n - 1.0) * win.s0 - win.s1) + L * win.u1 + win.v0;
        acc_t w = (acc_t)g->w0 * L * 0.5 * n * (n - 1.0) + (acc_t)g->w1 * n;
        const acc_t m_l = n * L;
        if (next_whole) {
            if (partial > 0.0f) {
                a += win.s0 * (m_l * g->pw0 + g->pw1) + m_l * next.w + g->tail[e].x;
                w += m_l * g->pw0 + g->pw1;
            }
        } else if (!whole || partial > 0.0f) {
            end_walk(g->slopes, width, height, periodic, ex, ey, m_l, win.s0,
                     whole ? partial : g->period + 1.0f, g->segments, g->seg_offset, g->seg_data, &a, &w);
        }
        a -= g->tail[p].y;
        w -= g->origin_w;
        float2 acc = g->accum[p];
        g->accum[p] = (float2)(acc.x + g->dir_weight * (float)a, acc.y + g->dir_weight * (float)w);
    }

    // Slide the window one period on: drop m = 0, shift m -> m - 1, and
    // take in the period K - 1 when the chain still has it.
    const float4 f0 = win.count > 0 ? g->sums[p] : (float4)(0.0f);  // m = 0 is p itself
    const acc_t s0 = win.s0, s1 = win.s1, u0 = win.u0;
    win.s2 = win.s2 - 2.0 * s1 + s0 - f0.x;
    win.s1 = s1 - s0 + f0.x;
    win.s0 = s0 - f0.x;
    win.u1 = win.u1 - u0 + f0.y;
    win.u0 = u0 - f0.y;
    win.v0 -= f0.z;
    win.nonzero -= nonzero_sums(f0);
    win.count -= win.count > 0;
    if (k_whole > 0 && next_whole) {
        window_add(&win, next, K - 1.0);
        win.count += 1;
    }
    // A window over flat texels sums to exactly zero, not to the rounding
    // left behind by the texels that slid out.
    if (win.nonzero == 0)
        win.s0 = win.s1 = win.s2 = win.u0 = win.u1 = win.v0 = 0;
    c->win = win;

    c->x += step_x;
    c->y += step_y;
    c->nx += step_x;
    c->ny += step_y;
    if (periodic) {
        c->x = relief_wrap(c->x, width);
        c->y = relief_wrap(c->y, height);
        c->nx = relief_wrap(c->nx, width);
        c->ny = relief_wrap(c->ny, height);
    }
    c->k += 1;
}

// RELIEF_LANES chains per work-item, walked in lockstep: neighbouring chains
// start at neighbouring texels, so on a CPU, where one work-item runs at a
// time, the lanes share cache lines. GPUs get the same from neighbouring
// work-items and use one lane.
#ifndef RELIEF_LANES
#define RELIEF_LANES 1
#endif

__kernel void rays_chain_windows(__global const float2* slopes, int width, int height, int periodic,
                                 int step_x, int step_y, __global const int2* chain_start, int chains,
                                 int cycle, int k_whole, float period, float w0, float w1, float pw0,
                                 float pw1, float partial, int segments, __constant int2* seg_offset,
                                 __constant float4* seg_data, __global const float4* sums,
                                 __global const float2* tail, int reanchor, float dir_weight,
                                 __global const uchar* active, int tile, int tiles_x, int4 fft_rect,
                                 __global float2* accum)
{
    const int first = get_global_id(0) * RELIEF_LANES;
    if (first >= chains)
        return;
    const float origin_len = fmin(seg_data[0].z, (float)(k_whole * period + partial));
    const ChainArgs g = {slopes,     width,    height,  periodic, step_x,
                         step_y,     cycle,    k_whole, period,   w0,
                         w1,         pw0,      pw1,     partial,  segments,
                         seg_offset, seg_data, sums,    tail,     reanchor,
                         accum,      active,   tile,    tiles_x,  0.5 * (acc_t)origin_len * origin_len,
                         dir_weight, fft_rect};
    Chain lane[RELIEF_LANES];
    const int lanes = min(RELIEF_LANES, chains - first);
    for (int l = 0; l < lanes; ++l)
        chain_begin(&lane[l], chain_start[first + l], &g);
    for (int busy = lanes; busy > 0;) {
        busy = 0;
        for (int l = 0; l < lanes; ++l)
            if (!lane[l].done) {
                chain_step(&lane[l], &g);
                busy += !lane[l].done;
            }
    }
}

// Periodic textures: every window is full (K periods), every chain is a
// cycle of the same length and no walk leaves the texture, so the step has
// no branches. RELIEF_LANES neighbouring chains are kept in arrays (one
// entry per lane) and stepped together in a loop the compiler can turn
// into SIMD code. Same results as rays_chain_windows.
__kernel void rays_cycle_windows(int width, int height, int step_x, int step_y,
                                 __global const int2* chain_start, int chains, int cycle, int k_whole,
                                 float period, float w0, float w1, float pw0, float pw1, float partial,
                                 float origin_len, __global const float4* sums, __global const float2* tail,
                                 float dir_weight, __global const uchar* active, int tile, int tiles_x,
                                 __global float2* accum)
{
    const int first = get_global_id(0) * RELIEF_LANES;
    if (first >= chains)
        return;
    const int lanes = min(RELIEF_LANES, chains - first);
    const acc_t L = period, K = k_whole, km1 = K - 1.0;
    // a = ca*s0 + cb*(s2 + s1) + cc*s1 + L*u1 + v0 (+ the partial period)
    const acc_t ca = (acc_t)w0 * L * 0.5 * K * (K - 1.0) + (acc_t)w1 * (K - 1.0);
    const acc_t cb = -(acc_t)w0 * L * 0.5, cc = -(acc_t)w1;
    const acc_t m_l = K * L;
    const acc_t with_partial = partial > 0.0f ? 1.0 : 0.0;
    const acc_t pq = with_partial * (m_l * pw0 + pw1);
    const acc_t grow = k_whole > 0 ? 1.0 : 0.0;  // K = 0: the window stays empty
    const float wsum = (float)((acc_t)w0 * L * 0.5 * K * (K - 1.0) + (acc_t)w1 * K + pq -
                               0.5 * (acc_t)origin_len * origin_len);
    acc_t s0[RELIEF_LANES], s1[RELIEF_LANES], s2[RELIEF_LANES], u0[RELIEF_LANES], u1[RELIEF_LANES],
        v0[RELIEF_LANES];
    int nz[RELIEF_LANES], x[RELIEF_LANES], y[RELIEF_LANES], nx[RELIEF_LANES], ny[RELIEF_LANES];
    for (int l = 0; l < lanes; ++l) {
        const int2 st = chain_start[first + l];
        x[l] = st.x;
        y[l] = st.y;
        nx[l] = relief_wrap(st.x + k_whole * step_x, width);
        ny[l] = relief_wrap(st.y + k_whole * step_y, height);
        const Window win = window_from_scratch(sums, width, height, 1, step_x, step_y, st.x, st.y, k_whole);
        s0[l] = win.s0;
        s1[l] = win.s1;
        s2[l] = win.s2;
        u0[l] = win.u0;
        u1[l] = win.u1;
        v0[l] = win.v0;
        nz[l] = win.nonzero;
    }
    for (int k = 0; k < cycle; ++k) {
        for (int l = 0; l < lanes; ++l) {
            const int p = y[l] * width + x[l], e = ny[l] * width + nx[l];
            const float4 f0 = (float)grow * sums[p];
            const float4 next = sums[e];
            const float on = active[(y[l] / tile) * tiles_x + x[l] / tile] ? dir_weight : 0.0f;
            const acc_t a = ca * s0[l] + cb * (s2[l] + s1[l]) + cc * s1[l] + L * u1[l] + v0[l] + s0[l] * pq +
                            with_partial * (m_l * next.w + tail[e].x) - tail[p].y;
            const float2 acc = accum[p];
            accum[p] = (float2)(acc.x + on * (float)a, acc.y + on * wsum);
            // Slide: drop m = 0, shift, take in m = K - 1.
            const acc_t a0 = s0[l], a1 = s1[l], b0 = u0[l];
            const acc_t fx = f0.x, fy = f0.y, nxv = grow * next.x, nyv = grow * next.y;
            s2[l] = s2[l] - 2.0 * a1 + a0 - fx + km1 * km1 * nxv;
            s1[l] = a1 - a0 + fx + km1 * nxv;
            s0[l] = a0 - fx + nxv;
            u1[l] = u1[l] - b0 + fy + km1 * nyv;
            u0[l] = b0 - fy + nyv;
            v0[l] = v0[l] - f0.z + grow * next.z;
            nz[l] += (k_whole > 0 ? nonzero_sums(next) : 0) - nonzero_sums(f0);
            const acc_t keep = nz[l] != 0 ? 1.0 : 0.0;
            s0[l] *= keep;
            s1[l] *= keep;
            s2[l] *= keep;
            u0[l] *= keep;
            u1[l] *= keep;
            v0[l] *= keep;
            x[l] += step_x;
            y[l] += step_y;
            nx[l] += step_x;
            ny[l] += step_y;
            x[l] = x[l] >= width ? x[l] - width : (x[l] < 0 ? x[l] + width : x[l]);
            y[l] = y[l] >= height ? y[l] - height : (y[l] < 0 ? y[l] + height : y[l]);
            nx[l] = nx[l] >= width ? nx[l] - width : (nx[l] < 0 ? nx[l] + width : nx[l]);
            ny[l] = ny[l] >= height ? ny[l] - height : (ny[l] < 0 ? ny[l] + height : ny[l]);
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
    out[gid] = v.y > 0.0f && v.x != 0.0f ? -v.x / v.y : 0.0f;
}
