// SPDX-License-Identifier: Apache-2.0
// Distortion correction by per-node descent with a line search (Brent's,
// golden-section or ternary) and over-relaxation (docs/design.md §4.5, after
// Zirr & Ritschel, HPG 2019). The stage's kernels fill four files, built as
// one program in this order: this one (the energy, its constants and sums),
// correct_nodes.cl (the node phase), correct_global.cl (global steps) and
// correct_hats.cl (hat moves).
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
            const int x = relief_wrap_or_out(tx + dx, tiles_x, periodic & 1);
            const int y = relief_wrap_or_out(ty + dy, tiles_y, periodic & 2);
            if (x < 0 || y < 0)
                continue;
            for (int s = 0; s < slots; ++s)
                any |= moved[s * count + y * tiles_x + x];
        }
    active[t] = any;
}
