// SPDX-License-Identifier: Apache-2.0
// Distortion correction, hat moves (docs/design.md §4.5.3b): the nodes under a
// bilinear hat of radius B nodes, centred on the lattice of spacing B, move
// together by t x their hat weight along one direction d, the hat's negative
// energy gradient. A node's own line search moves one node; the smooth error a
// cliff leaves needs whole regions to move at once, and per-node steps pass it
// on a node per iteration. Hats of one class (centre index mod 2 on each axis)
// are 2B apart and share no triangle, so each moves alone and only when the
// energy of the triangles it touches falls: the total never rises.
// Built in one program after correct.cl, correct_nodes.cl and
// correct_global.cl (the host joins the stage's files in that order):
// energy_t, the CORRECT_* constants and the correct_* helpers come from
// there.

// The constant part of a triangle from its surface edges fa, fb:
// (A3, |fa|^2, fa.fb, |fb|^2).
inline float4 hat_triangle_constants(float3 fa, float3 fb)
{
    return (float4)(0.5f * length(cross(fa, fb)), dot(fa, fa), dot(fa, fb), dot(fb, fb));
}

// Weight along one axis of node x in the hat centred at c (both in [0, n)),
// radius B: 1 - |x - c| / B within B (across the seam where the axis wraps),
// else 0, and 0 at a fixed axis's two border nodes (they stay pinned).
inline float hat_axis_weight(int x, int c, int B, int n, int wraps)
{
    int d = x - c;
    if (wraps) {
        if (2 * d > n)
            d -= n;
        else if (2 * d < -n)
            d += n;
    } else if (x <= 0 || x >= n - 1) {
        return 0.0f;
    }
    d = abs(d);
    return d < B ? 1.0f - (float)d / (float)B : 0.0f;
}

// Visits the triangles the hat at (ci, cj) changes: for each owner node p
// with a weighted corner, T1 and T2 unless their three corners move alike.
// HAT_VISIT(ea, eb, T, wa, wb): the texture edges from p (texels), the
// triangle's constants (hat_triangle_constants: computed again on each
// visit, which costs less than a buffer of them at 32 bytes a node) and the
// edges' weights relative to p's (an edge changes by t (wa - wp) d).
#define HAT_TRIANGLES(HAT_VISIT)                                                                             \
    for (int oy = cj - B + 1; oy <= cj + B; ++oy) {                                                          \
        int y = oy;                                                                                          \
        if (periodic & 2)                                                                                    \
            y = relief_wrap(y, ny);                                                                          \
        else if (y < 1 || y >= ny)                                                                           \
            continue;                                                                                        \
        const int y0 = y == 0 ? ny - 1 : y - 1;                                                              \
        const float wy = hat_axis_weight(y, cj, B, ny, periodic & 2);                                        \
        const float wy0 = hat_axis_weight(y0, cj, B, ny, periodic & 2);                                      \
        for (int ox = ci - B; ox < ci + B; ++ox) {                                                           \
            int x = ox;                                                                                      \
            if (periodic & 1)                                                                                \
                x = relief_wrap(x, nx);                                                                      \
            else if (x < 0 || x + 1 >= nx)                                                                   \
                continue;                                                                                    \
            const int x1 = x + 1 == nx ? 0 : x + 1;                                                          \
            const float wx = hat_axis_weight(x, ci, B, nx, periodic & 1);                                    \
            const float wx1 = hat_axis_weight(x1, ci, B, nx, periodic & 1);                                  \
            const float wp = wx * wy, w2 = wx1 * wy, w1 = wx1 * wy0, w0 = wx * wy0;                          \
            if (w2 == wp && w1 == wp && w0 == wp)                                                            \
                continue;                                                                                    \
            const int p = y * nx + x, n1 = y0 * nx + x1;                                                     \
            const float2 cp = c[p];                                                                          \
            const float zp = z[p];                                                                           \
            const float2 e1 = (float2)(1.0f, -1.0f) + c[n1] - cp;                                            \
            const float3 f1 = (float3)(1.0f, -1.0f, z[n1] - zp);                                             \
            if (w2 != wp || w1 != wp) {                                                                      \
                const int n2 = y * nx + x1;                                                                  \
                const float2 e2 = (float2)(1.0f, 0.0f) + c[n2] - cp;                                         \
                const float4 T = hat_triangle_constants((float3)(1.0f, 0.0f, z[n2] - zp), f1);               \
                HAT_VISIT(e2, e1, T, (w2 - wp), (w1 - wp));                                                  \
            }                                                                                                \
            if (w1 != wp || w0 != wp) {                                                                      \
                const int n0 = y0 * nx + x;                                                                  \
                const float2 e0 = (float2)(0.0f, -1.0f) + c[n0] - cp;                                        \
                const float4 T = hat_triangle_constants(f1, (float3)(0.0f, -1.0f, z[n0] - zp));              \
                HAT_VISIT(e1, e0, T, (w1 - wp), (w0 - wp));                                                  \
            }                                                                                                \
        }                                                                                                    \
    }

// A triangle's energy from its texture edges and constants, as
// correct_triangle_energy8.
inline energy_t hat_triangle_energy(float2 ea, float2 eb, float4 T, float theta)
{
    const float auv = 0.5f * (ea.y * eb.x - ea.x * eb.y);
    if (!(auv > 0.0f))
        return INFINITY;
    const float q = T.y * dot(eb, eb) - 2.0f * T.z * dot(ea, eb) + T.w * dot(ea, ea);
    const float inv = 1.0f / (T.x * auv);
    const float k = (T.x * T.x + auv * auv) * inv;
    return (energy_t)(0.25f * q * inv) * correct_pow_theta_total((energy_t)k, theta);
}

// Compensated sum: a hat adds up to 8 B^2 triangles, and its move is
// judged by a relative fall of 1e-6.
#define HAT_SUM_ADD(sum, comp, v)                                                                            \
    {                                                                                                        \
        const energy_t y_ = (v)-comp;                                                                        \
        const energy_t t_ = sum + y_;                                                                        \
        comp = (t_ - sum) - y_;                                                                              \
        sum = t_;                                                                                            \
    }

// One class of hats at scale B, one work-item per hat: hats_x x hats_y
// centres at multiples of B, those with (index mod 2) = (class_x, class_y).
// The step: E(t) of the touched triangles is fitted by a parabola through
// E(0), E'(0) = -|g| and a probe at half the bracket (then 1/16, 1/128 of it
// while nothing was lower); the probe or the parabola's minimum, whichever
// is lower, is taken if it lowers E by more than CORRECT_GAIN relative.
// The hat's fall is added to gain[] at its centre node.
kernel void correct_hat_phase(global float2* c, global const float* z, int nx, int ny, int periodic, int B,
                              int class_x, int class_y, int hats_x, int hats_y, float theta,
                              global energy_t* gain)
{
    const int h = get_global_id(0);
    const int per_x = (hats_x - class_x + 1) / 2, per_y = (hats_y - class_y + 1) / 2;
    if (h >= per_x * per_y)
        return;
    const int ci = (2 * (h % per_x) + class_x) * B, cj = (2 * (h / per_x) + class_y) * B;

    // The touched triangles' energy gradient g along the hat: the sum over
    // them of (wa - wp) dE/dea + (wb - wp) dE/deb.
    float2 g = (float2)(0.0f);
#define HAT_GRADIENT(ea, eb, T, wa, wb)                                                                      \
    {                                                                                                        \
        const float auv = 0.5f * (ea.y * eb.x - ea.x * eb.y);                                                \
        const float q = T.y * dot(eb, eb) - 2.0f * T.z * dot(ea, eb) + T.w * dot(ea, ea);                    \
        const float inv = 1.0f / (T.x * auv);                                                                \
        const float kk = (T.x * T.x + auv * auv) * inv;                                                      \
        const energy_t kt = correct_pow_theta_total((energy_t)kk, theta);                                    \
        const energy_t e = (energy_t)(0.25f * q * inv) * kt;                                                 \
        /* E = Q/(4 A3 Auv) k^theta: dE/dQ = k^theta/(4 A3 Auv); dE/dAuv = */                                \
        /* E (-1/Auv + theta/k (1/A3 - A3/Auv^2)).                        */                                 \
        const float dQ = (float)((energy_t)(0.25f * inv) * kt);                                              \
        const float dA = (float)e * (-1.0f / auv + theta / kk * (1.0f / T.x - T.x / (auv * auv)));           \
        const float2 dQa = 2.0f * (T.w * ea - T.z * eb), dQb = 2.0f * (T.y * eb - T.z * ea);                 \
        const float2 dAa = 0.5f * (float2)(-eb.y, eb.x), dAb = 0.5f * (float2)(ea.y, -ea.x);                 \
        g += (wa) * (dQ * dQa + dA * dAa) + (wb) * (dQ * dQb + dA * dAb);                                    \
    }
    HAT_TRIANGLES(HAT_GRADIENT)
#undef HAT_GRADIENT
    const float gn = length(g);
    if (!(gn > 0.0f) || !isfinite(gn))
        return;
    const float2 d = -g / gn;

    // The bracket: B x the per-node cap, or the first flip (Auv is linear
    // in t: both edges change along the same d, and d x d = 0).
    float tmax = CORRECT_MAX_STEP * B;
#define HAT_FLIP(ea, eb, T, wa, wb)                                                                          \
    {                                                                                                        \
        const float2 da = (wa)*d, db = (wb)*d;                                                               \
        const float auv = 0.5f * (ea.y * eb.x - ea.x * eb.y);                                                \
        const float a1 = 0.5f * (da.y * eb.x + ea.y * db.x - da.x * eb.y - ea.x * db.y);                     \
        if (a1 < 0.0f)                                                                                       \
            tmax = fmin(tmax, -auv / a1);                                                                    \
    }
    HAT_TRIANGLES(HAT_FLIP)
#undef HAT_FLIP
    if (!(tmax > 0.0f))
        return;

#define HAT_ADD(ea, eb, T, wa, wb)                                                                           \
    HAT_SUM_ADD(sum_, comp_,                                                                                 \
                hat_triangle_energy(ea + (t_probe * (wa)) * d, eb + (t_probe * (wb)) * d, T, theta))
    // Every energy, E0 = E(0) included, comes from this one evaluation: a
    // move is judged, and its fall counted in gain[], by the difference of
    // two evaluations, and a compiler may fuse multiplies and adds
    // differently in two copies of one formula, which near-degenerate
    // triangles (E ~ Auv^-(1 + theta)) magnify far beyond rounding.
    energy_t E0 = 0, best = 0;
    float best_t = 0.0f, probe = 0.5f * tmax, t_probe = 0.0f;
    for (int k = 0, tries = 0; k < 7; ++k) {
        energy_t sum_ = 0, comp_ = 0;
        HAT_TRIANGLES(HAT_ADD)
        float t_next = 0.0f;
        if (k == 0) {
            if (!isfinite(sum_))
                return;
            E0 = best = sum_;
            t_next = probe;
        } else {
            const bool finite = isfinite(sum_);
            if (finite && sum_ < best) {
                best = sum_;
                best_t = t_probe;
            }
            if (t_probe == probe && finite) {
                // After a probe, the parabola E(t) ~ E0 - |g| t + a t^2's
                // minimum.
                const energy_t a = (sum_ - E0 + (energy_t)gn * probe) / ((energy_t)probe * probe);
                if (a > 0) {
                    const float t = fmin((float)((energy_t)gn / (2 * a)), 0.95f * tmax);
                    if (t > 0.0f && t != probe)
                        t_next = t;
                }
            }
            if (t_next == 0.0f) {  // the try is over: stop, or probe nearer
                if (best_t != 0.0f || ++tries == 3)
                    break;
                probe *= 0.125f;
                t_next = probe;
            }
        }
        t_probe = t_next;
    }
#undef HAT_ADD
    if (best_t == 0.0f || !(best < E0 - (energy_t)CORRECT_GAIN * E0))
        return;
    for (int oy = cj - B + 1; oy < cj + B; ++oy) {
        const int y = relief_wrap_or_out(oy, ny, periodic & 2);
        if (y < 0)
            continue;
        const float wy = hat_axis_weight(y, cj, B, ny, periodic & 2);
        for (int ox = ci - B + 1; ox < ci + B; ++ox) {
            const int x = relief_wrap_or_out(ox, nx, periodic & 1);
            if (x < 0)
                continue;
            const float w = hat_axis_weight(x, ci, B, nx, periodic & 1) * wy;
            if (w != 0.0f)
                c[y * nx + x] += (best_t * w) * d;
        }
    }
    gain[cj * nx + ci] += E0 - best;
}
#undef HAT_TRIANGLES
#undef HAT_SUM_ADD
