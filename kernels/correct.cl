// SPDX-License-Identifier: Apache-2.0
// Distortion correction by per-node descent with a line search (Brent's,
// golden-section or ternary) and over-relaxation (docs/design.md §4.5, after
// Zirr & Ritschel, HPG 2019).
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

typedef relief_acc_t energy_t;  // (common.h)

#define CORRECT_TILE 16                // nodes per tile side (8 x 8 quads, one work-group)
#define CORRECT_STEPS 31               // ternary search: at most this many steps ...
#define CORRECT_WIDTH 1e-6f            // ... or until the bracket is this fraction of its start
#define CORRECT_MAX_STEP 2.0f          // texels: the bracket when no triangle can flip
#define CORRECT_FLAT 1e-7f             // relative energy difference below float rounding
#define CORRECT_GAIN 1e-6f             // smallest relative fan-energy decrease that moves a node
#define CORRECT_GOLDEN_R 0.381966011f  // (3 - sqrt 5) / 2: golden-section interior points
// Golden-section steps (one evaluation each): the bracket ends at 0.618^10
// = 0.8% of its start.
#define CORRECT_GOLDEN_STEPS 10
// Brent's minimiser: at most this many evaluations, each step's precision
// this fraction of the step. Measured on 1024^2 maps (bench_correct): 4 to 6
// evaluations converge to within 0.02% of one another's energy; the hard
// maps (steep cliffs, hundreds of iterations) need the step-relative
// precision that a fixed golden-section count lacks.
#define CORRECT_BRENT_EVALS 5
#define CORRECT_BRENT_REL 0.01f
#ifndef CORRECT_SEARCH
#define CORRECT_SEARCH 2  // the host sets it: 0 ternary, 1 golden section, 2 Brent
#endif

// k^theta: the host builds the program with CORRECT_ITHETA set when theta
// is a whole number (the default 5), for multiplication instead of
// pow()/pown(), which CPU back ends may call as library functions (they
// dominated the line search 10:1).
// In energy_t (double where the device has fp64): at theta = 20, k^theta
// passes float's range once the area ratio reaches about 60 (a 60-texel step).
#ifdef CORRECT_ITHETA
RELIEF_DEFINE_POWN(correct_pown_total, energy_t)
RELIEF_DEFINE_POWN(correct_pown8, float8)
#endif

inline energy_t correct_pow_theta_total(energy_t x, float theta)
{
#ifdef CORRECT_ITHETA
    return correct_pown_total(x, CORRECT_ITHETA);
#else
    return pow(x, (energy_t)theta);
#endif
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

RELIEF_DEFINE_GROUP_SUM(correct_group_sum, energy_t)

// Nodes per work-item in the sums below: each work-item adds its nodes in
// order, then the work-group's items by halving. A work-group's halving
// rounds cost CPU back ends a pass over every item each (PoCL: 8 ns a node
// at one node an item, about half the energy kernel's time and all of the
// gain sum's).
#define CORRECT_SUM_NODES 8  // the energy's float8 lanes (and the step limits') assume 8

#ifdef RELIEF_FP64
typedef double8 energy8_t;
#define convert_energy8 convert_double8
#else
typedef float8 energy8_t;
#define convert_energy8 convert_float8
#endif
#ifdef CORRECT_ITHETA
RELIEF_DEFINE_POWN(correct_pown_total8, energy8_t)
#endif

// The energies of eight triangles [p, a, b] in lanes (a, b: the texture
// edges, fa, fb the surface edges), infinite
// where flipped; with stats, s1/s2 and s1 s2 (the anisotropy and the area
// ratio).
inline energy8_t correct_triangle_energy8(float8 ax, float8 ay, float8 bx, float8 by, float8 fax, float8 fay,
                                          float8 faz, float8 fbx, float8 fby, float8 fbz, float theta,
                                          float8* aniso, float8* area)
{
    const float8 auv = 0.5f * (ay * bx - ax * by);
    const float8 cx = fay * fbz - faz * fby, cy = faz * fbx - fax * fbz, cz = fax * fby - fay * fbx;
    const float8 a3 = 0.5f * sqrt(cx * cx + cy * cy + cz * cz);
    const float8 m11 = fax * fax + fay * fay + faz * faz, m12 = fax * fbx + fay * fby + faz * fbz,
                 m22 = fbx * fbx + fby * fby + fbz * fbz;
    const float8 q = m11 * (bx * bx + by * by) - 2.0f * m12 * (ax * bx + ay * by) + m22 * (ax * ax + ay * ay);
    const float8 inv = 1.0f / (a3 * auv);
    const float8 k = (a3 * a3 + auv * auv) * inv;
#ifdef CORRECT_ITHETA
    const energy8_t kt = correct_pown_total8(convert_energy8(k), CORRECT_ITHETA);
#else
    const energy8_t kt = pow(convert_energy8(k), (energy8_t)(theta));
#endif
    const int8 good = auv > 0.0f;
    if (aniso) {
        // s1/s2 from k' = s1/s2 + s2/s1 >= 2; s1 s2 = A3 / Auv.
        const float8 kk = 0.25f * q * inv;
        *aniso = select((float8)(INFINITY), 0.5f * (kk + sqrt(fmax(kk * kk - 4.0f, 0.0f))), good);
        *area = select((float8)(INFINITY), a3 / auv, good);
    }
    return select((energy8_t)(INFINITY), convert_energy8(0.25f * q * inv) * kt,
#ifdef RELIEF_FP64
                  convert_long8(good)
#else
                  good
#endif
    );
}

// Total energy: the triangles each node owns plus its fixation term, summed
// in a fixed order (deterministic), one partial per work-group. With
// `stats`, also writes per owned triangle the anisotropy s1/s2 and the
// area ratio s1 s2 (float4 per node: T1 then T2; NaN where a triangle does
// not exist at a fixed boundary). Work-item k sums the nodes first +
// CORRECT_SUM_NODES (8) k onwards, their triangles in float8 lanes (scalar
// code cost 14% of a 1024^2 wall's run): the statistics of a large map come
// in chunks that fit one device buffer; stats[0] is node `first`,
// partial[0] its group.
kernel void correct_energy(global const float2* c, global const float* z, global const float* fix_w,
                           int use_fix, int nx, int ny, int periodic, float theta, global energy_t* partial,
                           local energy_t* scratch, global float4* stats, int want_stats, int first)
{
    const int base = first + 8 * get_global_id(0);
    // Per lane (node): the edges to its neighbours (1,0), (1,-1), (0,-1);
    // a node that owns no triangle (or lies past the end) holds a flat
    // fan's, masked out below.
    float e2x[8], e2y[8], e1x[8], e1y[8], e0x[8], e0y[8], z2[8], z1[8], z0[8];
    int owns[8];
#pragma unroll
    for (int n = 0; n < 8; ++n) {
        const int gid = base + n;
        const int i = gid % nx, j = gid / nx;
        e2x[n] = 1.0f;
        e2y[n] = 0.0f;
        e1x[n] = 1.0f;
        e1y[n] = -1.0f;
        e0x[n] = 0.0f;
        e0y[n] = -1.0f;
        z2[n] = z1[n] = z0[n] = 0.0f;
        // `periodic`: bit 0 x wraps, bit 1 y wraps; along a fixed axis the
        // last column (first row) owns no triangle.
        owns[n] = gid < nx * ny && ((periodic & 1) || i + 1 < nx) && ((periodic & 2) || j >= 1);
        if (!owns[n])
            continue;
        const float2 cp = c[gid];
        const float zp = z[gid];
        const int n2 = correct_node(i + 1, j, nx, ny), n1 = correct_node(i + 1, j - 1, nx, ny),
                  n0 = correct_node(i, j - 1, nx, ny);
        const float2 e2 = (float2)(1.0f, 0.0f) + c[n2] - cp;
        const float2 e1 = (float2)(1.0f, -1.0f) + c[n1] - cp;
        const float2 e0 = (float2)(0.0f, -1.0f) + c[n0] - cp;
        e2x[n] = e2.x;
        e2y[n] = e2.y;
        e1x[n] = e1.x;
        e1y[n] = e1.y;
        e0x[n] = e0.x;
        e0y[n] = e0.y;
        z2[n] = z[n2] - zp;
        z1[n] = z[n1] - zp;
        z0[n] = z[n0] - zp;
    }
    const float8 E2x = vload8(0, e2x), E2y = vload8(0, e2y), E1x = vload8(0, e1x), E1y = vload8(0, e1y),
                 E0x = vload8(0, e0x), E0y = vload8(0, e0y);
    const float8 F2z = vload8(0, z2), F1z = vload8(0, z1), F0z = vload8(0, z0);
    float8 an1, ar1, an2, ar2;
    const energy8_t t1 =
        correct_triangle_energy8(E2x, E2y, E1x, E1y, (float8)(1.0f), (float8)(0.0f), F2z, (float8)(1.0f),
                                 (float8)(-1.0f), F1z, theta, want_stats ? &an1 : 0, &ar1);
    const energy8_t t2 =
        correct_triangle_energy8(E1x, E1y, E0x, E0y, (float8)(1.0f), (float8)(-1.0f), F1z, (float8)(0.0f),
                                 (float8)(-1.0f), F0z, theta, want_stats ? &an2 : 0, &ar2);
    energy_t e1s[8], e2s[8];
    vstore8(t1, 0, e1s);
    vstore8(t2, 0, e2s);
    float a1s[8], r1s[8], a2s[8], r2s[8];
    if (want_stats) {
        vstore8(an1, 0, a1s);
        vstore8(ar1, 0, r1s);
        vstore8(an2, 0, a2s);
        vstore8(ar2, 0, r2s);
    }
    energy_t sum = 0;
    for (int n = 0; n < 8 && base + n < nx * ny; ++n) {
        const int gid = base + n;
        if (owns[n])
            sum += e1s[n] + e2s[n];
        if (use_fix)
            sum += (energy_t)correct_fix_energy(c[gid], fix_w[gid]);
        if (want_stats)
            stats[gid - first] = owns[n] ? (float4)(a1s[n], r1s[n], a2s[n], r2s[n]) : (float4)(NAN);
    }
    correct_group_sum(sum, scratch, partial);
}

// Sum of the per-node energy falls of an iteration (correct_phase's gain;
// zero where nothing moved), CORRECT_SUM_NODES a work-item, per work-group
// in a fixed order: the energy change that decides convergence, without
// recomputing the energy.
kernel void correct_gain_sum(global const energy_t* gain, int count, global energy_t* partial,
                             local energy_t* scratch)
{
    const int base = CORRECT_SUM_NODES * get_global_id(0);
    energy_t sum = 0;
    for (int n = 0; n < CORRECT_SUM_NODES && base + n < count; ++n)
        sum += gain[base + n];
    correct_group_sum(sum, scratch, partial);
}

// Which tiles must run phase `phase` next: those with a node that moved,
// in them or in a neighbouring tile, during the last `slots` phase launches
// (including this phase's previous launch). A node whose fan has not
// changed since its own last update, which moved nothing, would again move
// nothing; skipping it changes no bit of the result.
kernel void correct_active(global const uchar* moved, int slots, int tiles_x, int tiles_y, int periodic,
                           global uchar* active)
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
            if (periodic & 1)
                x = relief_wrap(x, tiles_x);
            if (periodic & 2)
                y = relief_wrap(y, tiles_y);
            if (x < 0 || y < 0 || x >= tiles_x || y >= tiles_y)
                continue;
            for (int s = 0; s < slots; ++s)
                any |= moved[s * count + y * tiles_x + x];
        }
    active[t] = any;
}

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

// ---------------------------------------------------------------------------
// Global steps (docs/design.md §4.5.3c): every node moves at once along
// D = -S, S = sum over scales l of P^l R^l G, G the energy gradient of every
// node, R full weighting onto the lattice of every other node (weights
// 1/2, 1, 1/2 per axis), P = R^T bilinear interpolation back; pinned nodes
// are zero at every scale. Since G.D = -sum |R^l G|^2 (masked), D descends;
// the scales' sum is the multilevel (BPX) preconditioner of an
// elasticity-like energy, whose hats have scale-free stiffness in 2-D. The
// host searches the step along D by the total energy, within the first
// flip anywhere.

// Whether node (i, j) is pinned: a border node of a fixed axis.
inline int correct_pinned(int i, int j, int nx, int ny, int periodic)
{
    return (!(periodic & 1) && (i == 0 || i == nx - 1)) || (!(periodic & 2) && (j == 0 || j == ny - 1));
}

// The energy gradient with respect to each node's offset (texels), summed
// over its six fan triangles (each as correct_triangle_energy8, by the line
// search's formulas: correct_fan_gradient); zero at pinned nodes. K^theta in
// energy_t: without fp64 a fan past float's range gives an infinite
// gradient, and the host then takes no step.
kernel void correct_gradient(global const float2* c, global const float* z, int nx, int ny, int periodic,
                             float theta, global float2* grad)
{
    const int p = get_global_id(0);
    if (p >= nx * ny)
        return;
    const int i = p % nx, j = p / nx;
    float2 g = (float2)(0.0f);
    if (!correct_pinned(i, j, nx, ny, periodic)) {
        float2 e[6];
        float3 f[6];
        correct_fan_edges(c, z, nx, ny, i, j, e, f);
        const FanLanes L = correct_fan_lanes(e, f);
        if (!(L.kmax > 0.0f) || !isfinite(L.kmax)) {
            g = (float2)(NAN);  // a flipped or degenerate fan: no step
        } else {
            // Scaled by K^-theta in the lanes (float), back in energy_t.
            const float2 gs = correct_fan_gradient(&L, 1.0f / L.kmax, theta);
            const energy_t kt = correct_pow_theta_total((energy_t)L.kmax, theta);
            g = (float2)((float)(gs.x * kt), (float)(gs.y * kt));
        }
    }
    grad[p] = g;
}

// Full weighting of a fine field onto the coarse lattice (coarse node (I, J)
// at fine node (2I, 2J)): the sum of the nine fine nodes around it,
// weighted 1/2 per axis off centre, in a fixed order; beyond a fixed axis's
// ends nothing; zero at the coarse lattice's pinned nodes.
kernel void correct_restrict(global const float2* fine, int fnx, int fny, int periodic, global float2* coarse,
                             int cnx, int cny)
{
    const int q = get_global_id(0);
    if (q >= cnx * cny)
        return;
    const int I = q % cnx, J = q / cnx;
    float2 sum = (float2)(0.0f);
    if (!correct_pinned(I, J, cnx, cny, periodic))
        for (int dy = -1; dy <= 1; ++dy) {
            int y = 2 * J + dy;
            if (periodic & 2)
                y = relief_wrap(y, fny);
            else if (y < 0 || y >= fny)
                continue;
            for (int dx = -1; dx <= 1; ++dx) {
                int x = 2 * I + dx;
                if (periodic & 1)
                    x = relief_wrap(x, fnx);
                else if (x < 0 || x >= fnx)
                    continue;
                sum += ((dx == 0 ? 1.0f : 0.5f) * (dy == 0 ? 1.0f : 0.5f)) * fine[y * fnx + x];
            }
        }
    coarse[q] = sum;
}

// fine += the coarse field interpolated bilinearly at the fine nodes (the
// transpose of correct_restrict); zero at pinned fine nodes.
kernel void correct_prolong(global const float2* coarse, int cnx, int cny, global float2* fine, int fnx,
                            int fny, int periodic)
{
    const int p = get_global_id(0);
    if (p >= fnx * fny)
        return;
    const int i = p % fnx, j = p / fnx;
    if (correct_pinned(i, j, fnx, fny, periodic)) {
        fine[p] = (float2)(0.0f);
        return;
    }
    const int I0 = i / 2, J0 = j / 2;
    const int I1 = (i & 1) ? ((periodic & 1) ? relief_wrap(I0 + 1, cnx) : I0 + 1) : I0;
    const int J1 = (j & 1) ? ((periodic & 2) ? relief_wrap(J0 + 1, cny) : J0 + 1) : J0;
    const float w = ((i & 1) ? 0.5f : 1.0f) * ((j & 1) ? 0.5f : 1.0f);
    float2 v = w * coarse[J0 * cnx + I0];
    if (I1 != I0 && I1 < cnx)
        v += w * coarse[J0 * cnx + I1];
    if (J1 != J0 && J1 < cny) {
        v += w * coarse[J1 * cnx + I0];
        if (I1 != I0 && I1 < cnx)
            v += w * coarse[J1 * cnx + I1];
    }
    fine[p] += v;
}

// The first step t > 0 at which a node's owned triangle flips moving every
// node by -t S[node] (Auv(t) is quadratic: both edges change linearly),
// and |S| at the node: per work-group, the least t and the largest |S|
// (min and max: the same whatever the order). x = t, y = |S|. Eight nodes
// a work-item, their triangles in float8 lanes without branches: the
// roots' branches kept the CPU back end's code scalar (and the work-group
// halving visits every item), 9% of a 1024^2 wall's run.
kernel void correct_step_limits(global const float2* c, global const float2* S, int nx, int ny, int periodic,
                                global float2* partial, local float2* scratch)
{
    const int base = 8 * get_global_id(0);
    float2 lim = (float2)(INFINITY, 0.0f);
    float ea_x[2][8], ea_y[2][8], eb_x[2][8], eb_y[2][8], da_x[2][8], da_y[2][8], db_x[2][8], db_y[2][8];
    int owns[8];
    const float2 o[3] = {(float2)(1.0f, 0.0f), (float2)(1.0f, -1.0f), (float2)(0.0f, -1.0f)};
#pragma unroll
    for (int n = 0; n < 8; ++n) {
        const int p = base + n;
        owns[n] = 0;
        for (int t = 0; t < 2; ++t)
            ea_x[t][n] = ea_y[t][n] = eb_x[t][n] = eb_y[t][n] = da_x[t][n] = da_y[t][n] = db_x[t][n] =
                db_y[t][n] = 0.0f;
        if (p >= nx * ny)
            continue;
        const int i = p % nx, j = p / nx;
        lim.y = fmax(lim.y, length(S[p]));
        if (!(((periodic & 1) || i + 1 < nx) && ((periodic & 2) || j >= 1)))
            continue;
        owns[n] = -1;
        const int m[3] = {correct_node(i + 1, j, nx, ny), correct_node(i + 1, j - 1, nx, ny),
                          correct_node(i, j - 1, nx, ny)};
        for (int t = 0; t < 2; ++t) {
            const float2 ea = o[t] + c[m[t]] - c[p], eb = o[t + 1] + c[m[t + 1]] - c[p];
            const float2 da = S[p] - S[m[t]], db = S[p] - S[m[t + 1]];  // d/dt of the edges
            ea_x[t][n] = ea.x;
            ea_y[t][n] = ea.y;
            eb_x[t][n] = eb.x;
            eb_y[t][n] = eb.y;
            da_x[t][n] = da.x;
            da_y[t][n] = da.y;
            db_x[t][n] = db.x;
            db_y[t][n] = db.y;
        }
    }
    const int8 own = vload8(0, owns);
    float8 first = (float8)(INFINITY);
    for (int t = 0; t < 2; ++t) {
        const float8 eax = vload8(0, ea_x[t]), eay = vload8(0, ea_y[t]), ebx = vload8(0, eb_x[t]),
                     eby = vload8(0, eb_y[t]), dax = vload8(0, da_x[t]), day = vload8(0, da_y[t]),
                     dbx = vload8(0, db_x[t]), dby = vload8(0, db_y[t]);
        // 2 Auv(t) = a0 + a1 t + a2 t^2
        const float8 a0 = eay * ebx - eax * eby;
        const float8 a1 = day * ebx + eay * dbx - dax * eby - eax * dby;
        const float8 a2 = day * dbx - dax * dby;
        const float8 linear = select((float8)(INFINITY), -a0 / a1, a1 < 0.0f);
        const float8 disc = a1 * a1 - 4.0f * a2 * a0;
        // The roots without cancellation: q = -(a1 + sign(a1) sq) / 2.
        const float8 qq = -0.5f * (a1 + copysign(sqrt(fmax(disc, 0.0f)), a1));
        const float8 r1 = qq / a2, r2 = select((float8)(INFINITY), a0 / qq, qq != 0.0f);
        const float8 quad =
            select((float8)(INFINITY),
                   fmin(select((float8)(INFINITY), r1, r1 > 0.0f), select((float8)(INFINITY), r2, r2 > 0.0f)),
                   disc >= 0.0f);
        first = fmin(first, select((float8)(INFINITY), select(quad, linear, a2 == 0.0f), own));
    }
    const float4 f4 = fmin(first.lo, first.hi);
    lim.x = fmin(fmin(f4.x, f4.y), fmin(f4.z, f4.w));
    const int lid = get_local_id(0);
    scratch[lid] = lim;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int s = get_local_size(0) / 2; s > 0; s >>= 1) {
        if (lid < s)
            scratch[lid] =
                (float2)(fmin(scratch[lid].x, scratch[lid + s].x), fmax(scratch[lid].y, scratch[lid + s].y));
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (lid == 0)
        partial[get_group_id(0)] = scratch[0];
}

// G.S per work-group (CORRECT_SUM_NODES nodes a work-item, in order): the
// step's slope is -G.S.
kernel void correct_dot(global const float2* G, global const float2* S, int count, global energy_t* partial,
                        local energy_t* scratch)
{
    const int base = CORRECT_SUM_NODES * get_global_id(0);
    energy_t sum = 0;
    for (int n = 0; n < CORRECT_SUM_NODES && base + n < count; ++n)
        sum += (energy_t)G[base + n].x * S[base + n].x + (energy_t)G[base + n].y * S[base + n].y;
    correct_group_sum(sum, scratch, partial);
}

// out = c - t S: the offsets after a step t along D = -S.
kernel void correct_step(global const float2* c, global const float2* S, float t, int count,
                         global float2* out)
{
    const int p = get_global_id(0);
    if (p < count)
        out[p] = c[p] - t * S[p];
}

// ---------------------------------------------------------------------------
// Hat moves (docs/design.md §4.5.3b): the nodes under a bilinear hat of
// radius B nodes, centred on the lattice of spacing B, move together by
// t x their hat weight along one direction d, the hat's negative energy
// gradient. A node's own line search moves one node; the smooth error a
// cliff leaves needs whole regions to move at once, and per-node steps pass
// it on a node per iteration. Hats of one class (centre index mod 2 on each
// axis) are 2B apart and share no triangle, so each moves alone and only
// when the energy of the triangles it touches falls: the total never rises.

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
        int y = oy;
        if (periodic & 2)
            y = relief_wrap(y, ny);
        else if (y < 0 || y >= ny)
            continue;
        const float wy = hat_axis_weight(y, cj, B, ny, periodic & 2);
        for (int ox = ci - B + 1; ox < ci + B; ++ox) {
            int x = ox;
            if (periodic & 1)
                x = relief_wrap(x, nx);
            else if (x < 0 || x >= nx)
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
