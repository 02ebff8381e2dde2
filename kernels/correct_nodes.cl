// SPDX-License-Identifier: Apache-2.0
// Distortion correction, the node phase (docs/design.md §4.5.2): each node's
// line search along its fan's descent direction, Brent's, golden-section or
// ternary (CORRECT_SEARCH), with over-relaxation.
// Built in one program after correct.cl (the host joins the stage's files
// in that order): energy_t, the CORRECT_* constants and the correct_*
// helpers come from there.

inline float8 correct_pow_theta8(float8 x, float theta)
{
#ifdef CORRECT_ITHETA
    return correct_pown8(x, CORRECT_ITHETA);
#else
    return pow(x, (float8)(theta));
#endif
}

// Energy of node p's fan (plus fixation) after moving p by t along d, times
// K^-theta, K the fan's largest k at t = 0: the line search compares
// energies of one fan only, and unscaled ones overflow float at theta = 20
// (k ~ 60). The six triangles sit in lanes 0-5 of float8s (lanes 6, 7 hold
// a zero-energy dummy): per triangle, Auv(t) = a0 + a1 t and
// Q(t) = q0 + q1 t + q2 t^2.
// Vector lanes rather than a loop because CPU back ends vectorise only
// innermost loops, and the work-item loop is not one here.
typedef struct {
    float8 a0, a1, q0, q1, q2, a3;
    float inv_k;      // 1 / K
    float fix_scale;  // K^-theta, for the fixation term
} FanPolys;

inline float correct_fan_energy(float t, const FanPolys* fp, float2 cp, float2 d, float w, int use_fix,
                                float theta)
{
    const float8 auv = fp->a0 + t * fp->a1;
    const float8 q = fp->q0 + t * (fp->q1 + t * fp->q2);
    const float8 inv = 1.0f / (fp->a3 * auv);
    const float8 k = (fp->a3 * fp->a3 + auv * auv) * inv * fp->inv_k;
    const float8 e8 = select((float8)(INFINITY), 0.25f * q * inv * correct_pow_theta8(k, theta), auv > 0.0f);
    const float4 e4 = e8.lo + e8.hi;
    float e = (e4.x + e4.y) + (e4.z + e4.w);
    if (use_fix)
        e += fp->fix_scale * correct_fix_energy(cp + t * d, w);
    return e;
}

#ifndef CORRECT_NODES
#define CORRECT_NODES 1
#endif

// The texture edges e[k] and surface edges f[k] from node (i, j) to its
// neighbours N0..N5 (texels).
RELIEF_INLINE void correct_fan_edges(global const float2* c, global const float* z, int nx, int ny, int i,
                                     int j, float2* e, float3* f)
{
    const int p = j * nx + i;
    const float2 cp = c[p];
    const float zp = z[p];
    const int2 offs[6] = {(int2)(0, -1), (int2)(1, -1), (int2)(1, 0),
                          (int2)(0, 1),  (int2)(-1, 1), (int2)(-1, 0)};
#pragma unroll
    for (int k = 0; k < 6; ++k) {
        const int q = correct_node(i + offs[k].x, j + offs[k].y, nx, ny);
        const float2 o = convert_float2(offs[k]);
        e[k] = o + c[q] - cp;
        // Component by component: a float3 made of a float2 and a float
        // crashes Oclgrind's uninitialised-value checks on unoptimised code
        // (tests/portability/float3_from_float2.cpp).
        f[k] = (float3)(o.x, o.y, z[q] - zp);
    }
}

// The six fan triangles [p, Na, Nb] of a node in lanes 0-5 (Na, Nb =
// neighbours (2,1) (1,0) (0,5) (5,4) (4,3) (3,2)); lanes 6, 7 repeat
// triangle 0 so that they hold finite values, and are masked out of every
// sum. In vector lanes, as the line search's energies: scalar code cost the
// line search as much as twelve of its steps, and the global steps'
// gradient 3x its time. kmax: the fan's largest k (area ratio term).
typedef struct {
    float8 e1x, e1y, e2x, e2y, m11, m12, m22, a3, auv, q, inv, kk;
    float kmax;
} FanLanes;

inline FanLanes correct_fan_lanes(const float2* e, const float3* f)
{
    FanLanes L;
    L.e1x = (float8)(e[2].x, e[1].x, e[0].x, e[5].x, e[4].x, e[3].x, e[2].x, e[2].x);
    L.e1y = (float8)(e[2].y, e[1].y, e[0].y, e[5].y, e[4].y, e[3].y, e[2].y, e[2].y);
    L.e2x = (float8)(e[1].x, e[0].x, e[5].x, e[4].x, e[3].x, e[2].x, e[1].x, e[1].x);
    L.e2y = (float8)(e[1].y, e[0].y, e[5].y, e[4].y, e[3].y, e[2].y, e[1].y, e[1].y);
    const float8 f1x = (float8)(f[2].x, f[1].x, f[0].x, f[5].x, f[4].x, f[3].x, f[2].x, f[2].x);
    const float8 f1y = (float8)(f[2].y, f[1].y, f[0].y, f[5].y, f[4].y, f[3].y, f[2].y, f[2].y);
    const float8 f1z = (float8)(f[2].z, f[1].z, f[0].z, f[5].z, f[4].z, f[3].z, f[2].z, f[2].z);
    const float8 f2x = (float8)(f[1].x, f[0].x, f[5].x, f[4].x, f[3].x, f[2].x, f[1].x, f[1].x);
    const float8 f2y = (float8)(f[1].y, f[0].y, f[5].y, f[4].y, f[3].y, f[2].y, f[1].y, f[1].y);
    const float8 f2z = (float8)(f[1].z, f[0].z, f[5].z, f[4].z, f[3].z, f[2].z, f[1].z, f[1].z);
    const float8 nx3 = f1y * f2z - f1z * f2y, ny3 = f1z * f2x - f1x * f2z, nz3 = f1x * f2y - f1y * f2x;
    L.a3 = 0.5f * sqrt(nx3 * nx3 + ny3 * ny3 + nz3 * nz3);
    L.m11 = f1x * f1x + f1y * f1y + f1z * f1z;
    L.m12 = f1x * f2x + f1y * f2y + f1z * f2z;
    L.m22 = f2x * f2x + f2y * f2y + f2z * f2z;
    const float8 e11 = L.e1x * L.e1x + L.e1y * L.e1y, e12 = L.e1x * L.e2x + L.e1y * L.e2y,
                 e22 = L.e2x * L.e2x + L.e2y * L.e2y;
    L.auv = 0.5f * (L.e1y * L.e2x - L.e1x * L.e2y);
    L.q = L.m11 * e22 - 2.0f * L.m12 * e12 + L.m22 * e11;
    L.inv = 1.0f / (L.a3 * L.auv);
    L.kk = (L.a3 * L.a3 + L.auv * L.auv) * L.inv;
    const float4 k4 = fmax(L.kk.lo, L.kk.hi);
    L.kmax = fmax(fmax(k4.x, k4.y), fmax(k4.z, k4.w));
    return L;
}

// The analytic gradient of the fan's energy with respect to the node's
// texture position (vertex 0 of every fan triangle), times K^-theta with
// 1/K = inv_k (as the line search's fan energies).
inline float2 correct_fan_gradient(const FanLanes* L, float inv_k, float theta)
{
    const int8 fan = (int8)(-1, -1, -1, -1, -1, -1, 0, 0);
    const float8 gk = correct_pow_theta8(L->kk * inv_k, theta);  // (k/K)^theta
    const float8 F = 0.25f * L->q * L->inv;
    const float8 dE_dQ = 0.25f * L->inv * gk;
    const float8 dE_dA =
        F * (-gk / L->auv + theta * (gk / L->kk) * (1.0f / L->a3 - L->a3 / (L->auv * L->auv)));
    const float8 w22 = 2.0f * (L->m22 - L->m12), w11 = 2.0f * (L->m11 - L->m12);
    const float8 gx8 = select(
        (float8)(0.0f), -(dE_dQ * (w22 * L->e1x + w11 * L->e2x) + dE_dA * 0.5f * (L->e1y - L->e2y)), fan);
    const float8 gy8 = select(
        (float8)(0.0f), -(dE_dQ * (w22 * L->e1y + w11 * L->e2y) + dE_dA * 0.5f * (L->e2x - L->e1x)), fan);
    const float4 gx4 = gx8.lo + gx8.hi, gy4 = gy8.lo + gy8.hi;
    return (float2)((gx4.x + gx4.y) + (gx4.z + gx4.w), (gy4.x + gy4.y) + (gy4.z + gy4.w));
}

// One node's line-search problem.
typedef struct {
    FanPolys fp;
    float2 cp, d;
    float w, tmax;
    int p;  // node index, or -1 when the node does not move
} NodeSearch;

// Gradient, direction and bracket of node (i, j); p = -1 when it cannot or
// need not move (outside the grid, wrong class, fixed border, zero gradient).
RELIEF_INLINE NodeSearch correct_prepare(global const float2* c, global const float* z,
                                         global const float* fix_w, int use_fix, int nx, int ny, int periodic,
                                         int class_x, int class_y, int i, int j, float theta)
{
    NodeSearch ns;
    ns.p = -1;
    ns.tmax = 1.0f;
    ns.cp = ns.d = (float2)(0.0f);
    ns.w = 0.0f;
    ns.fp.a0 = ns.fp.a3 = (float8)(1.0f);
    ns.fp.a1 = ns.fp.q0 = ns.fp.q1 = ns.fp.q2 = (float8)(0.0f);
    ns.fp.inv_k = ns.fp.fix_scale = 1.0f;
    if (i >= nx || j >= ny)
        return ns;
    const int px = periodic & 1, py = (periodic >> 1) & 1;
    const int odd_x = px && (nx & 1), odd_y = py && (ny & 1);
    if ((class_x == 2) != (odd_x && i == nx - 1) || (class_y == 2) != (odd_y && j == ny - 1))
        return ns;
    // Along a fixed axis the border nodes stay where they are.
    if ((!px && (i == 0 || i == nx - 1)) || (!py && (j == 0 || j == ny - 1)))
        return ns;

    const int p = j * nx + i;
    const float2 cp = c[p];
    const float w = use_fix ? fix_w[p] : 0.0f;
    float2 e[6];
    float3 f[6];
    correct_fan_edges(c, z, nx, ny, i, j, e, f);

    const FanLanes L = correct_fan_lanes(e, f);
    const float kmax = L.kmax;
    if (!(kmax > 0.0f) || !isfinite(kmax))
        return ns;  // a flipped or degenerate fan: nothing to search
    const float inv_k = 1.0f / kmax;
    // K^-theta scales the fixation term; only it needs the power.
    const float fix_scale = use_fix ? exp2(-theta * log2(kmax)) : 1.0f;
    float2 g = correct_fan_gradient(&L, inv_k, theta);
    const int8 fan = (int8)(-1, -1, -1, -1, -1, -1, 0, 0);
    if (use_fix) {
        const float u = 1.0f - w * w * dot(cp, cp);
        g += fix_scale * w * w * cp / (u * u);
    }
    const float gn = length(g);
    if (!(gn > 0.0f) || !isfinite(gn))
        return ns;
    const float2 d = -g / gn;  // unit descent direction
    const float2 s = -d;       // every fan edge e = Na - p changes by t * s

    // Per triangle, Auv(t) = a0 + a1 t and Q(t) = q0 + q1 t + q2 t^2; the
    // bracket ends where the first of them flips (Auv = 0).
    const float8 a1 = 0.5f * (s.x * (L.e1y - L.e2y) + s.y * (L.e2x - L.e1x));
    const float8 e1s = L.e1x * s.x + L.e1y * s.y, e2s = L.e2x * s.x + L.e2y * s.y;
    const float8 q1 = 2.0f * (L.m11 * e2s - L.m12 * (e1s + e2s) + L.m22 * e1s);
    const float8 q2 = L.m11 - 2.0f * L.m12 + L.m22;  // |s| = 1
    const float8 flip = select((float8)(CORRECT_MAX_STEP), -L.auv / a1, a1 < 0.0f);
    const float4 t4 = fmin(flip.lo, flip.hi);
    float tmax = fmin(CORRECT_MAX_STEP, fmin(fmin(t4.x, t4.y), fmin(t4.z, t4.w)));
    if (use_fix && w > 0.0f) {
        // |c + t d| = 1/w: the fixation barrier.
        const float cd = dot(cp, d);
        const float disc = cd * cd - dot(cp, cp) + 1.0f / (w * w);
        tmax = fmin(tmax, -cd + sqrt(fmax(disc, 0.0f)));
    }
    if (!(tmax > 0.0f))
        return ns;
    // Lanes 6, 7: a zero-energy dummy (Q = 0, Auv = A3 = 1).
    ns.fp.a0 = select((float8)(1.0f), L.auv, fan);
    ns.fp.a1 = select((float8)(0.0f), a1, fan);
    ns.fp.q0 = select((float8)(0.0f), L.q, fan);
    ns.fp.q1 = select((float8)(0.0f), q1, fan);
    ns.fp.q2 = select((float8)(0.0f), q2, fan);
    ns.fp.a3 = select((float8)(1.0f), L.a3, fan);
    ns.fp.inv_k = inv_k;
    ns.fp.fix_scale = fix_scale;
    ns.cp = cp;
    ns.d = d;
    ns.w = w;
    ns.tmax = tmax;
    ns.p = p;
    return ns;
}

// Moves the node to the searched step t (fan energy Et), or, over-relaxed,
// to relax * t when that is lower than the start E0 too (successive
// over-relaxation: long-wavelength errors, which one exact step per node
// shrinks slowly, shrink faster). A move must lower the fan energy by more
// than rounding: moves within the noise would keep converged tiles busy
// forever. Either way the fan energy falls, so the total never rises.
inline void correct_finish(global float2* c, global uchar* moved, int moved_at, global energy_t* gain,
                           const NodeSearch* ns, float t, float Et, float E0, float relax, int use_fix,
                           float theta)
{
    if (ns->p < 0)
        return;
    const float floor_e = E0 - CORRECT_GAIN * E0;
    if (relax != 1.0f && relax * t < ns->tmax) {
        const float Er = correct_fan_energy(relax * t, &ns->fp, ns->cp, ns->d, ns->w, use_fix, theta);
        if (Er < floor_e && isfinite(Er)) {
            t *= relax;
            Et = Er;
        }
    }
    if (!(Et < floor_e) || !isfinite(Et))
        return;
    const float2 next = ns->cp + t * ns->d;
    if (next.x != ns->cp.x || next.y != ns->cp.y) {
        c[ns->p] = next;
        moved[moved_at] = 1;
        // The total energy falls by the fan's fall: nodes moving together
        // share no triangle, and the fixation term is the node's own.
        gain[ns->p] = (energy_t)(E0 - Et) * correct_pow_theta_total((energy_t)(1.0f / ns->fp.inv_k), theta);
    }
}

// One phase of an iteration: every node of phase class (class_x, class_y)
// moves along its negative energy gradient by a line search over its
// bracket (Brent's by default, golden-section or ternary), over-relaxed.
// Work-item = CORRECT_NODES neighbouring 2x2 quads of nodes along x, whose
// searches run in lockstep (independent dependency chains: a CPU core
// overlaps them; the search is otherwise latency-bound); work-group = one
// 16x16-node tile. Classes per axis: 0 = even, 1 = odd, 2 = the last node
// of an odd periodic axis (it neighbours node 0 across the seam, so it
// moves on its own). Nodes moving together share no triangle: the energy
// never rises.
kernel void correct_phase(global float2* c, global const float* z, global const float* fix_w, int use_fix,
                          int nx, int ny, int periodic, int class_x, int class_y, int tiles_x,
                          global const uchar* active, global uchar* moved, int moved_slot, float theta,
                          float relax, global energy_t* gain)
{
    // A tile is 8 / CORRECT_NODES x 8 work-items (16 x 16 nodes); a
    // work-group lies within one.
    const int tile = (get_global_id(1) / 8) * tiles_x + get_global_id(0) / (8 / CORRECT_NODES);
    if (!active[tile])
        return;
    const int j = 2 * get_global_id(1) + (class_y == 1);
    NodeSearch ns[CORRECT_NODES];
    float lo[CORRECT_NODES], hi[CORRECT_NODES];
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n) {
        const int i = 2 * (CORRECT_NODES * get_global_id(0) + n) + (class_x == 1);
        ns[n] = correct_prepare(c, z, fix_w, use_fix, nx, ny, periodic, class_x, class_y, i, j, theta);
        lo[n] = 0.0f;
        hi[n] = ns[n].tmax;
    }
#define FAN_E(n, t) correct_fan_energy((t), &ns[n].fp, ns[n].cp, ns[n].d, ns[n].w, use_fix, theta)
#if CORRECT_SEARCH == 2
    // Brent's minimiser (parabolic steps through the best three points,
    // golden-section steps when a parabola is not trusted), from the start
    // t = 0, whose energy is known, over [0, tmax]. Its precision is
    // relative to the step (CORRECT_BRENT_REL), so small and large steps
    // cost alike: a golden-section search to the same relative precision
    // needs ~20 evaluations for a step of 1e-3 of its bracket.
    float a[CORRECT_NODES], x[CORRECT_NODES], w[CORRECT_NODES], v[CORRECT_NODES];
    float fx[CORRECT_NODES], fw[CORRECT_NODES], fv[CORRECT_NODES], dd[CORRECT_NODES], ee[CORRECT_NODES],
        E0[CORRECT_NODES];
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n) {
        a[n] = x[n] = w[n] = v[n] = dd[n] = ee[n] = 0.0f;
        E0[n] = fx[n] = fw[n] = fv[n] = FAN_E(n, 0.0f);
    }
    for (int it = 0; it < CORRECT_BRENT_EVALS; ++it) {
#pragma unroll
        for (int n = 0; n < CORRECT_NODES; ++n) {
            const float b = hi[n], xm = 0.5f * (a[n] + b);
            const float tol1 = CORRECT_BRENT_REL * fabs(x[n]) + CORRECT_WIDTH * ns[n].tmax;
            const float tol2 = 2.0f * tol1;
            if (fabs(x[n] - xm) <= tol2 - 0.5f * (b - a[n]))
                continue;  // converged
            float step;
            bool golden = true;
            if (fabs(ee[n]) > tol1) {
                const float r = (x[n] - w[n]) * (fx[n] - fv[n]);
                float q = (x[n] - v[n]) * (fx[n] - fw[n]);
                float p = (x[n] - v[n]) * q - (x[n] - w[n]) * r;
                q = 2.0f * (q - r);
                if (q > 0.0f)
                    p = -p;
                q = fabs(q);
                const float e_old = ee[n];
                // A parabola through non-finite energies, or whose step is
                // not less than half the one before last, or that leaves
                // the bracket, is not trusted.
                if (isfinite(p) && isfinite(q) && fabs(p) < fabs(0.5f * q * e_old) && p > q * (a[n] - x[n]) &&
                    p < q * (b - x[n])) {
                    ee[n] = dd[n];
                    step = p / q;
                    const float u = x[n] + step;
                    if (u - a[n] < tol2 || b - u < tol2)
                        step = copysign(tol1, xm - x[n]);
                    golden = false;
                }
            }
            if (golden) {
                ee[n] = x[n] >= xm ? a[n] - x[n] : b - x[n];
                step = CORRECT_GOLDEN_R * ee[n];
            }
            dd[n] = step;
            const float u = fabs(step) >= tol1 ? x[n] + step : x[n] + copysign(tol1, step);
            const float fu = FAN_E(n, u);
            // Non-finite energies (a flip, overflow) count as higher.
            if (fu <= fx[n]) {
                if (u >= x[n])
                    a[n] = x[n];
                else
                    hi[n] = x[n];
                v[n] = w[n];
                fv[n] = fw[n];
                w[n] = x[n];
                fw[n] = fx[n];
                x[n] = u;
                fx[n] = fu;
            } else {
                if (u < x[n])
                    a[n] = u;
                else
                    hi[n] = u;
                if (!(fu > fw[n]) || w[n] == x[n]) {
                    v[n] = w[n];
                    fv[n] = fw[n];
                    w[n] = u;
                    fw[n] = fu;
                } else if (!(fu > fv[n]) || v[n] == x[n] || v[n] == w[n]) {
                    v[n] = u;
                    fv[n] = fu;
                }
            }
        }
    }
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n)
        correct_finish(c, moved, moved_slot + tile, gain, &ns[n], x[n], fx[n], E0[n], relax, use_fix, theta);
#elif CORRECT_SEARCH == 1
    // The interior point that survives a step is one of the next step's
    // two, so each step costs one evaluation. The step taken is the better
    // of the last two interior points, whose energies are known.
    float x1[CORRECT_NODES], x2[CORRECT_NODES], E1[CORRECT_NODES], E2[CORRECT_NODES];
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n) {
        x1[n] = CORRECT_GOLDEN_R * hi[n];
        x2[n] = hi[n] - CORRECT_GOLDEN_R * hi[n];
        E1[n] = FAN_E(n, x1[n]);
        E2[n] = FAN_E(n, x2[n]);
    }
    for (int step = 0; step < CORRECT_GOLDEN_STEPS; ++step) {
#pragma unroll
        for (int n = 0; n < CORRECT_NODES; ++n) {
            if (!(hi[n] - lo[n] > CORRECT_WIDTH * ns[n].tmax))
                continue;
            if (!isfinite(E1[n])) {
                // Overflow or NaN at x1 (the energy is finite at t = 0): the
                // minimum lies before it; start again on [lo, x1].
                hi[n] = x1[n];
                const float width = hi[n] - lo[n];
                x1[n] = lo[n] + CORRECT_GOLDEN_R * width;
                x2[n] = hi[n] - CORRECT_GOLDEN_R * width;
                E1[n] = FAN_E(n, x1[n]);
                E2[n] = FAN_E(n, x2[n]);
            } else if (isfinite(E2[n]) && fabs(E1[n] - E2[n]) <= CORRECT_FLAT * (E1[n] + E2[n])) {
                hi[n] = lo[n];  // no difference beyond rounding: stop here
            } else if (!isfinite(E2[n]) || E1[n] < E2[n]) {
                hi[n] = x2[n];
                x2[n] = x1[n];
                E2[n] = E1[n];
                x1[n] = lo[n] + CORRECT_GOLDEN_R * (hi[n] - lo[n]);
                E1[n] = FAN_E(n, x1[n]);
            } else {
                lo[n] = x1[n];
                x1[n] = x2[n];
                E1[n] = E2[n];
                x2[n] = hi[n] - CORRECT_GOLDEN_R * (hi[n] - lo[n]);
                E2[n] = FAN_E(n, x2[n]);
            }
        }
    }
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n) {
        const int second = !(E1[n] <= E2[n]);
        correct_finish(c, moved, moved_slot + tile, gain, &ns[n], second ? x2[n] : x1[n],
                       second ? E2[n] : E1[n], FAN_E(n, 0.0f), relax, use_fix, theta);
    }
#else
    for (int step = 0; step < CORRECT_STEPS; ++step) {
#pragma unroll
        for (int n = 0; n < CORRECT_NODES; ++n) {
            if (hi[n] - lo[n] > CORRECT_WIDTH * ns[n].tmax) {
                const float m1 = lo[n] + (hi[n] - lo[n]) * (1.0f / 3.0f);
                const float m2 = hi[n] - (hi[n] - lo[n]) * (1.0f / 3.0f);
                const float e1 = FAN_E(n, m1);
                const float e2 = FAN_E(n, m2);
                // The energy is finite at t = 0: an infinite (flipped,
                // overflowed) or NaN value at m1 or m2 puts the minimum
                // before it. Energies that no longer differ beyond rounding
                // cannot narrow the bracket further: stop (the midpoint is
                // kept).
                if (!isfinite(e1))
                    hi[n] = m1;
                else if (!isfinite(e2))
                    hi[n] = m2;
                else if (fabs(e1 - e2) <= CORRECT_FLAT * (e1 + e2))
                    hi[n] = lo[n] = 0.5f * (lo[n] + hi[n]);
                else if (e1 < e2)
                    hi[n] = m2;
                else
                    lo[n] = m1;
            }
        }
    }
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n) {
        const float t = 0.5f * (lo[n] + hi[n]);
        correct_finish(c, moved, moved_slot + tile, gain, &ns[n], t, FAN_E(n, t), FAN_E(n, 0.0f), relax,
                       use_fix, theta);
    }
#endif
#undef FAN_E
}
