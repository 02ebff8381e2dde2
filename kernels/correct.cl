// Distortion correction by per-node descent with a ternary line search
// (DESIGN.md §4.5, after Zirr & Ritschel, HPG 2019).
//
// Nodes form an nx × ny grid. Node p has a texture offset c[p] (float2, in
// texels of the current level) and a displaced height z[p] (texels: the
// world height times the level's width). Node p owns the triangles
// [p, p+(1,0), p+(1,-1)] and [p, p+(1,-1), p+(0,-1)]; its fan is the six
// triangles [p, Na, Nb] around it, with the neighbours
// N0..N5 = (0,-1) (1,-1) (1,0) (0,1) (-1,1) (-1,0). Putting p first in every
// fan triangle keeps the orientation of the owned ones (a rotation of the
// vertex order), so one formula serves both.
//
// Per triangle, with texture edges e1, e2 (corrected texture space) and 3D
// edges f1, f2 (the displaced surface), all in texels:
//   Auv = (e1.y e2.x - e1.x e2.y) / 2  (> 0 unless flipped; y points down)
//   A3  = |f1 x f2| / 2
//   Q   = |J|_F^2 * 4 Auv^2 = M11 (e2.e2) - 2 M12 (e1.e2) + M22 (e1.e1),
//         M = Gram matrix of f1, f2
//   s1/s2 + s2/s1 = Q / (4 A3 Auv),  s1 s2 = A3 / Auv
//   E = Q / (4 A3 Auv) * k^theta,  k = s1 s2 + 1/(s1 s2) = (A3^2 + Auv^2) / (A3 Auv)
// (one division per evaluation). A flipped or degenerate texture triangle
// has infinite energy.

#ifdef RELIEF_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double energy_t;
#else
typedef float energy_t;
#endif

#define CORRECT_TILE 16        // nodes per tile side (8 x 8 quads, one work-group)
#define CORRECT_STEPS 31       // ternary search: at most this many steps ...
#define CORRECT_WIDTH 1e-6f    // ... or until the bracket is this fraction of its start
#define CORRECT_MAX_STEP 2.0f  // texels: the bracket when no triangle can flip
#define CORRECT_FLAT 1e-7f     // relative energy difference below float rounding
#define CORRECT_GAIN 1e-6f     // smallest relative fan-energy decrease that moves a node

// k^theta. The host builds the program with CORRECT_ITHETA set when theta
// is a whole number (the default 5): repeated multiplication, unrolled by
// the compiler, instead of pow()/pown(), which CPU back ends may call as
// library functions (they dominated the line search 10:1).
inline float correct_pow_theta(float x, float theta, int itheta)
{
#ifdef CORRECT_ITHETA
    float r = 1.0f;
    for (int n = 0; n < CORRECT_ITHETA; ++n)
        r *= x;
    return r;
#else
    return pow(x, theta);
#endif
}

// In energy_t (double where the device has fp64): at theta = 20, k^theta
// passes float's range once the area ratio reaches about 60 (a 60-texel step).
inline energy_t correct_pow_theta_total(energy_t x, float theta)
{
#ifdef CORRECT_ITHETA
    energy_t r = 1;
    for (int n = 0; n < CORRECT_ITHETA; ++n)
        r *= x;
    return r;
#else
    return pow(x, (energy_t)theta);
#endif
}

inline energy_t correct_triangle_energy(float2 e1, float2 e2, float3 f1, float3 f2, float theta,
                                        int itheta)
{
    const float auv = 0.5f * (e1.y * e2.x - e1.x * e2.y);
    if (!(auv > 0.0f))
        return INFINITY;
    const float a3 = 0.5f * length(cross(f1, f2));
    const float m11 = dot(f1, f1), m12 = dot(f1, f2), m22 = dot(f2, f2);
    const float q = m11 * dot(e2, e2) - 2.0f * m12 * dot(e1, e2) + m22 * dot(e1, e1);
    const float inv = 1.0f / (a3 * auv);
    const float k = (a3 * a3 + auv * auv) * inv;
    return (energy_t)(0.25f * q * inv) * correct_pow_theta_total((energy_t)k, theta);
}

// Fixation energy of a node with weight w (texel units): 0.5 / (1 - w^2 |c|^2),
// infinite at and beyond |c| = 1/w.
inline float correct_fix_energy(float2 c, float w)
{
    const float u = 1.0f - w * w * dot(c, c);
    return u > 0.0f ? 0.5f / u : INFINITY;
}

inline int correct_node(int i, int j, int nx, int ny)
{
    return relief_wrap(j, ny) * nx + relief_wrap(i, nx);
}

// Total energy: the triangles each node owns plus its fixation term, summed
// per work-group in a fixed order (deterministic), one partial per group.
// With `stats`, also writes per owned triangle the anisotropy s1/s2 and the
// area ratio s1 s2 (float4 per node: T1 then T2; NaN where a triangle does
// not exist at a fixed boundary). Launched over the nodes [first, first +
// count) (count a multiple of the group size): the statistics of a large
// map come in chunks that fit one device buffer; stats[0] is node `first`,
// partial[0] its group.
kernel void correct_energy(global const float2* c, global const float* z,
                           global const float* fix_w, int use_fix, int nx, int ny, int periodic,
                           float theta, int itheta, global energy_t* partial,
                           local energy_t* scratch, global float4* stats, int want_stats,
                           int first)
{
    const int gid = first + get_global_id(0), lid = get_local_id(0);
    energy_t sum = 0;
    if (gid < nx * ny) {
        const int i = gid % nx, j = gid / nx;
        float4 st = (float4)(NAN);
        if (periodic || (i + 1 < nx && j >= 1)) {
            const float2 cp = c[gid];
            const float zp = z[gid];
            const int n2 = correct_node(i + 1, j, nx, ny), n1 = correct_node(i + 1, j - 1, nx, ny),
                      n0 = correct_node(i, j - 1, nx, ny);
            const float2 e2 = (float2)(1.0f, 0.0f) + c[n2] - cp;
            const float2 e1 = (float2)(1.0f, -1.0f) + c[n1] - cp;
            const float2 e0 = (float2)(0.0f, -1.0f) + c[n0] - cp;
            const float3 f2 = (float3)(1.0f, 0.0f, z[n2] - zp);
            const float3 f1 = (float3)(1.0f, -1.0f, z[n1] - zp);
            const float3 f0 = (float3)(0.0f, -1.0f, z[n0] - zp);
            sum = correct_triangle_energy(e2, e1, f2, f1, theta, itheta) +
                  correct_triangle_energy(e1, e0, f1, f0, theta, itheta);
            if (want_stats) {
                // s1/s2 from k' = s1/s2 + s2/s1 >= 2; s1 s2 = A3 / Auv.
                float2 ee[2][2] = {{e2, e1}, {e1, e0}};
                float3 ff[2][2] = {{f2, f1}, {f1, f0}};
                float r[4];
                for (int t = 0; t < 2; ++t) {
                    const float2 a = ee[t][0], b = ee[t][1];
                    const float3 fa = ff[t][0], fb = ff[t][1];
                    const float auv = 0.5f * (a.y * b.x - a.x * b.y);
                    const float a3 = 0.5f * length(cross(fa, fb));
                    const float q = dot(fa, fa) * dot(b, b) - 2.0f * dot(fa, fb) * dot(a, b) +
                                    dot(fb, fb) * dot(a, a);
                    const float kk = q / (4.0f * a3 * auv);
                    r[2 * t] = auv > 0.0f ? 0.5f * (kk + sqrt(fmax(kk * kk - 4.0f, 0.0f)))
                                          : INFINITY;
                    r[2 * t + 1] = auv > 0.0f ? a3 / auv : INFINITY;
                }
                st = (float4)(r[0], r[1], r[2], r[3]);
            }
        }
        if (use_fix)
            sum += (energy_t)correct_fix_energy(c[gid], fix_w[gid]);
        if (want_stats)
            stats[gid - first] = st;
    }
    scratch[lid] = sum;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int s = get_local_size(0) / 2; s > 0; s >>= 1) {
        if (lid < s)
            scratch[lid] += scratch[lid + s];
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (lid == 0)
        partial[get_group_id(0)] = scratch[0];
}

// Which tiles must run phase `phase` next: those with a node that moved,
// in them or in a neighbouring tile, during the last `slots` phase launches
// (including this phase's previous launch). A node whose fan has not
// changed since its own last update, which moved nothing, would again move
// nothing; skipping it changes no bit of the result.
kernel void correct_active(global const uchar* moved, int slots, int tiles_x, int tiles_y,
                           int periodic, global uchar* active)
{
    const int t = get_global_id(0);
    const int count = tiles_x * tiles_y;
    if (t >= count)
        return;
    const int tx = t % tiles_x, ty = t / tiles_x;
    uchar any = 0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            int x = tx + dx, y = ty + dy;
            if (periodic) {
                x = relief_wrap(x, tiles_x);
                y = relief_wrap(y, tiles_y);
            } else if (x < 0 || y < 0 || x >= tiles_x || y >= tiles_y) {
                continue;
            }
            for (int s = 0; s < slots; ++s)
                any |= moved[s * count + y * tiles_x + x];
        }
    active[t] = any;
}

inline float8 correct_pow_theta8(float8 x, float theta)
{
#ifdef CORRECT_ITHETA
    // By squaring: the shortest dependency chain (x^5 = (x^2)^2 x).
    float8 r = (float8)(1.0f), b = x;
    for (int n = CORRECT_ITHETA; n > 0; n >>= 1) {
        if (n & 1)
            r *= b;
        b *= b;
    }
    return r;
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

inline float correct_fan_energy(float t, const FanPolys* fp, float2 cp, float2 d, float w,
                                int use_fix, float theta)
{
    const float8 auv = fp->a0 + t * fp->a1;
    const float8 q = fp->q0 + t * (fp->q1 + t * fp->q2);
    const float8 inv = 1.0f / (fp->a3 * auv);
    const float8 k = (fp->a3 * fp->a3 + auv * auv) * inv * fp->inv_k;
    const float8 e8 = select((float8)(INFINITY), 0.25f * q * inv * correct_pow_theta8(k, theta),
                             auv > 0.0f);
    const float4 e4 = e8.lo + e8.hi;
    float e = (e4.x + e4.y) + (e4.z + e4.w);
    if (use_fix)
        e += fp->fix_scale * correct_fix_energy(cp + t * d, w);
    return e;
}

#ifndef CORRECT_NODES
#define CORRECT_NODES 1
#endif

// One node's line-search problem.
typedef struct {
    FanPolys fp;
    float2 cp, d;
    float w, tmax;
    int p;  // node index, or -1 when the node does not move
} NodeSearch;

// Gradient, direction and bracket of node (i, j); p = -1 when it cannot or
// need not move (outside the grid, wrong class, fixed border, zero gradient).
inline NodeSearch correct_prepare(global const float2* c, global const float* z,
                                  global const float* fix_w, int use_fix, int nx, int ny,
                                  int periodic, int class_x, int class_y, int i, int j,
                                  float theta, int itheta)
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
    const int odd_x = periodic && (nx & 1), odd_y = periodic && (ny & 1);
    if ((class_x == 2) != (odd_x && i == nx - 1) || (class_y == 2) != (odd_y && j == ny - 1))
        return ns;
    // Fixed boundary: border nodes stay where they are.
    if (!periodic && (i == 0 || j == 0 || i == nx - 1 || j == ny - 1))
        return ns;

    const int p = j * nx + i;
    const float2 cp = c[p];
    const float zp = z[p];
    const float w = use_fix ? fix_w[p] : 0.0f;
    const int2 offs[6] = {(int2)(0, -1), (int2)(1, -1), (int2)(1, 0),
                          (int2)(0, 1),  (int2)(-1, 1), (int2)(-1, 0)};
    float2 e[6];
    float3 f[6];
#pragma unroll
    for (int k = 0; k < 6; ++k) {
        const int q = correct_node(i + offs[k].x, j + offs[k].y, nx, ny);
        const float2 o = convert_float2(offs[k]);
        e[k] = o + c[q] - cp;
        f[k] = (float3)(o, z[q] - zp);
    }

    // Analytic gradient with respect to p's texture position (vertex 0 of
    // every fan triangle [p, Na, Nb]), times K^-theta (as the fan energy).
    float a3[6], m11[6], m12[6], m22[6], auvs[6], qs[6], kks[6];
    float kmax = 0.0f;
#pragma unroll
    for (int k = 0; k < 6; ++k) {
        const int ia = (8 - k) % 6, ib = (7 - k) % 6;  // (2,1) (1,0) (0,5) (5,4) (4,3) (3,2)
        const float2 e1 = e[ia], e2 = e[ib];
        const float3 f1 = f[ia], f2 = f[ib];
        a3[k] = 0.5f * length(cross(f1, f2));
        m11[k] = dot(f1, f1);
        m12[k] = dot(f1, f2);
        m22[k] = dot(f2, f2);
        auvs[k] = 0.5f * (e1.y * e2.x - e1.x * e2.y);
        qs[k] = m11[k] * dot(e2, e2) - 2.0f * m12[k] * dot(e1, e2) + m22[k] * dot(e1, e1);
        kks[k] = (a3[k] * a3[k] + auvs[k] * auvs[k]) / (a3[k] * auvs[k]);
        kmax = fmax(kmax, kks[k]);
    }
    if (!(kmax > 0.0f) || !isfinite(kmax))
        return ns;  // a flipped or degenerate fan: nothing to search
    const float inv_k = 1.0f / kmax;
    const float fix_scale = exp2(-theta * log2(kmax));
    float2 g = (float2)(0.0f);
#pragma unroll
    for (int k = 0; k < 6; ++k) {
        const int ia = (8 - k) % 6, ib = (7 - k) % 6;
        const float2 e1 = e[ia], e2 = e[ib];
        const float auv = auvs[k], q = qs[k], kk = kks[k];
        const float inv = 1.0f / (a3[k] * auv);
        const float gk = correct_pow_theta(kk * inv_k, theta, itheta);  // (k/K)^theta
        const float F = 0.25f * q * inv;
        const float dE_dQ = 0.25f * inv * gk;
        const float dE_dA = F * (-gk / auv + theta * (gk / kk) * (1.0f / a3[k] - a3[k] / (auv * auv)));
        const float2 dQ = 2.0f * (m22[k] - m12[k]) * e1 + 2.0f * (m11[k] - m12[k]) * e2;
        const float2 dA = 0.5f * (float2)(e1.y - e2.y, e2.x - e1.x);
        g -= dE_dQ * dQ + dE_dA * dA;
    }
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
    float a0[6], a1[6], q0[6], q1[6], q2[6];
    float tmax = CORRECT_MAX_STEP;
#pragma unroll
    for (int k = 0; k < 6; ++k) {
        const int ia = (8 - k) % 6, ib = (7 - k) % 6;
        const float2 e1 = e[ia], e2 = e[ib];
        a0[k] = 0.5f * (e1.y * e2.x - e1.x * e2.y);
        a1[k] = 0.5f * (s.x * (e1.y - e2.y) + s.y * (e2.x - e1.x));
        q0[k] = m11[k] * dot(e2, e2) - 2.0f * m12[k] * dot(e1, e2) + m22[k] * dot(e1, e1);
        q1[k] = 2.0f * (m11[k] * dot(e2, s) - m12[k] * (dot(e1, s) + dot(e2, s)) +
                        m22[k] * dot(e1, s));
        q2[k] = m11[k] - 2.0f * m12[k] + m22[k];  // |s| = 1
        if (a1[k] < 0.0f)
            tmax = fmin(tmax, -a0[k] / a1[k]);
    }
    if (use_fix && w > 0.0f) {
        // |c + t d| = 1/w: the fixation barrier.
        const float cd = dot(cp, d);
        const float disc = cd * cd - dot(cp, cp) + 1.0f / (w * w);
        tmax = fmin(tmax, -cd + sqrt(fmax(disc, 0.0f)));
    }
    if (!(tmax > 0.0f))
        return ns;
    ns.fp.a0 = (float8)(a0[0], a0[1], a0[2], a0[3], a0[4], a0[5], 1.0f, 1.0f);
    ns.fp.a1 = (float8)(a1[0], a1[1], a1[2], a1[3], a1[4], a1[5], 0.0f, 0.0f);
    ns.fp.q0 = (float8)(q0[0], q0[1], q0[2], q0[3], q0[4], q0[5], 0.0f, 0.0f);
    ns.fp.q1 = (float8)(q1[0], q1[1], q1[2], q1[3], q1[4], q1[5], 0.0f, 0.0f);
    ns.fp.q2 = (float8)(q2[0], q2[1], q2[2], q2[3], q2[4], q2[5], 0.0f, 0.0f);
    ns.fp.a3 = (float8)(a3[0], a3[1], a3[2], a3[3], a3[4], a3[5], 1.0f, 1.0f);
    ns.fp.inv_k = inv_k;
    ns.fp.fix_scale = fix_scale;
    ns.cp = cp;
    ns.d = d;
    ns.w = w;
    ns.tmax = tmax;
    ns.p = p;
    return ns;
}

// One phase of an iteration: every node of phase class (class_x, class_y)
// moves along its negative energy gradient by the ternary-searched step.
// Work-item = CORRECT_NODES neighbouring 2x2 quads of nodes along x, whose
// searches run in lockstep (independent dependency chains: a CPU core
// overlaps them; the search is otherwise latency-bound); work-group = one
// 16x16-node tile. Classes per axis: 0 = even, 1 = odd, 2 = the last node
// of an odd periodic axis (it neighbours node 0 across the seam, so it
// moves on its own). Nodes moving together share no triangle: the energy
// never rises.
kernel void correct_phase(global float2* c, global const float* z, global const float* fix_w,
                          int use_fix, int nx, int ny, int periodic, int class_x, int class_y,
                          int tiles_x, global const uchar* active, global uchar* moved,
                          int moved_slot, float theta, int itheta)
{
    const int tile = get_group_id(1) * tiles_x + get_group_id(0);
    if (!active[tile])
        return;
    const int j = 2 * get_global_id(1) + (class_y == 1);
    NodeSearch ns[CORRECT_NODES];
    float lo[CORRECT_NODES], hi[CORRECT_NODES];
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n) {
        const int i = 2 * (CORRECT_NODES * get_global_id(0) + n) + (class_x == 1);
        ns[n] = correct_prepare(c, z, fix_w, use_fix, nx, ny, periodic, class_x, class_y, i, j,
                                theta, itheta);
        lo[n] = 0.0f;
        hi[n] = ns[n].tmax;
    }
    for (int step = 0; step < CORRECT_STEPS; ++step) {
#pragma unroll
        for (int n = 0; n < CORRECT_NODES; ++n) {
            if (hi[n] - lo[n] > CORRECT_WIDTH * ns[n].tmax) {
                const float m1 = lo[n] + (hi[n] - lo[n]) * (1.0f / 3.0f);
                const float m2 = hi[n] - (hi[n] - lo[n]) * (1.0f / 3.0f);
                const float E1 = correct_fan_energy(m1, &ns[n].fp, ns[n].cp, ns[n].d, ns[n].w, use_fix, theta);
                const float E2 = correct_fan_energy(m2, &ns[n].fp, ns[n].cp, ns[n].d, ns[n].w, use_fix, theta);
                // The energy is finite at t = 0: an infinite (flipped,
                // overflowed) or NaN value at m1 or m2 puts the minimum
                // before it. Energies that no longer differ beyond rounding
                // cannot narrow the bracket further: stop (the midpoint is
                // kept).
                if (!isfinite(E1))
                    hi[n] = m1;
                else if (!isfinite(E2))
                    hi[n] = m2;
                else if (fabs(E1 - E2) <= CORRECT_FLAT * (E1 + E2))
                    hi[n] = lo[n] = 0.5f * (lo[n] + hi[n]);
                else if (E1 < E2)
                    hi[n] = m2;
                else
                    lo[n] = m1;
            }
        }
    }
#pragma unroll
    for (int n = 0; n < CORRECT_NODES; ++n) {
        if (ns[n].p < 0)
            continue;
        const float t = 0.5f * (lo[n] + hi[n]);
        const float E0 = correct_fan_energy(0.0f, &ns[n].fp, ns[n].cp, ns[n].d, ns[n].w, use_fix, theta);
        const float Et = correct_fan_energy(t, &ns[n].fp, ns[n].cp, ns[n].d, ns[n].w, use_fix, theta);
        // A step must lower the fan energy by more than rounding: moves
        // within the noise would keep converged tiles busy forever.
        if (!(Et < E0 - CORRECT_GAIN * E0) || !isfinite(Et))
            continue;
        const float2 next = ns[n].cp + t * ns[n].d;
        if (next.x != ns[n].cp.x || next.y != ns[n].cp.y) {
            c[ns[n].p] = next;
            moved[moved_slot + tile] = 1;
        }
    }
}
