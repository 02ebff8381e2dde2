// SPDX-License-Identifier: Apache-2.0
// Distortion correction, global steps (docs/design.md §4.5.3c): every node
// moves at once along D = -S, S = sum over scales l of P^l R^l G, G the energy
// gradient of every node, R full weighting onto the lattice of every other
// node (weights 1/2, 1, 1/2 per axis), P = R^T bilinear interpolation back;
// pinned nodes are zero at every scale. Since G.D = -sum |R^l G|^2 (masked), D
// descends; the scales' sum is the multilevel (BPX) preconditioner of an
// elasticity-like energy, whose hats have scale-free stiffness in 2-D. The
// host searches the step along D by the total energy, within the first flip
// anywhere.
// Built in one program after correct.cl and correct_nodes.cl (the host
// joins the stage's files in that order): energy_t, the CORRECT_* constants
// and the correct_* helpers come from there.

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
            const int y = relief_wrap_or_out(2 * J + dy, fny, periodic & 2);
            if (y < 0)
                continue;
            for (int dx = -1; dx <= 1; ++dx) {
                const int x = relief_wrap_or_out(2 * I + dx, fnx, periodic & 1);
                if (x < 0)
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
