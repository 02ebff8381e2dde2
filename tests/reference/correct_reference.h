// SPDX-License-Identifier: Apache-2.0
#pragma once
// Golden model of distortion correction (docs/design.md §4.5), in double, written
// for clarity: the per-triangle energy, the total energy, the analytic fan
// gradient and one full iteration of the four-phase ternary-search scheme.
// Offsets and heights are in texels; nodes are given directly (the caller
// builds centre or corner nodes).
#include <array>
#include <vector>

namespace relief::reference {

struct CorrectionGrid {
    int nx = 0, ny = 0;
    // Per axis: the grid wraps (the texture tiles along it), else the
    // border nodes at that axis's two ends are fixed.
    bool periodic_x = true, periodic_y = true;
    double theta = 5.0;
    std::vector<double> z;    // height per node, texels
    std::vector<double> fix;  // fixation weight per node, or empty
    enum class Search { Ternary, Golden, Brent };
    Search search = Search::Brent;  // the line search per node
    double relax = 1.5;             // over-relaxation factor (1 = the searched step)
};

using Vec2 = std::array<double, 2>;
using Vec3 = std::array<double, 3>;

// E = (s1/s2 + s2/s1) (s1 s2 + 1/(s1 s2))^theta of the map from the texture
// triangle (0, e1, e2) to the surface triangle (0, f1, f2); infinite when
// the texture triangle is flipped (y points down: positive orientation is
// e1.y e2.x - e1.x e2.y > 0).
double triangle_energy(const Vec2& e1, const Vec2& e2, const Vec3& f1, const Vec3& f2, double theta);

// Singular values s1 >= s2 of that map, by the eigenvalues of J^T J with
// J = F E^-1 (independent of the closed form above).
std::array<double, 2> triangle_singular_values(const Vec2& e1, const Vec2& e2, const Vec3& f1,
                                               const Vec3& f2);

// Total energy of offsets c (2 per node, texels): every node's two owned
// triangles [p, p+(1,0), p+(1,-1)], [p, p+(1,-1), p+(0,-1)] plus fixation.
double total_energy(const CorrectionGrid& g, const std::vector<double>& c);

// Energy of node p's six-triangle fan plus its fixation, and its gradient
// with respect to c[p] (analytic).
double fan_energy(const CorrectionGrid& g, const std::vector<double>& c, int i, int j);
Vec2 fan_gradient(const CorrectionGrid& g, const std::vector<double>& c, int i, int j);

// One iteration: the phases (x mod 2, y mod 2) = (0,0), (1,0), (0,1), (1,1)
// (plus the last node of an odd periodic axis on its own), each node
// stepping along its negative gradient by a line search over the flip (and
// fixation) bracket: Brent's minimiser (5 evaluations, precision 1% of the
// step), golden section (10 steps) or ternary (31 steps); then relax x that
// step when its energy is below the start's as well.
void iterate(const CorrectionGrid& g, std::vector<double>& c);

// One sweep of hat moves (docs/design.md §4.5.3b), without fixation: for
// each scale B = 2, 4, ... while both axes hold two hats a class (a
// periodic axis of n nodes: n a multiple of 2B and at least 4B; a fixed
// one: n >= 2B + 1), for each class (centre index mod 2 per axis), each hat
// centred at a multiple of B moves its nodes by t w d, w the bilinear hat
// weight (1 - |dx|/B)(1 - |dy|/B) (0 at fixed borders), d the negative
// gradient of the total energy along w (the sum of w x each node's
// gradient), normalised; t from the energy of the triangles whose corners'
// weights differ: a probe at half the bracket [0, min(2B, first flip)] and
// the minimum of the parabola through E(0), E'(0) and it (then 1/16 and
// 1/128 of the bracket while neither was lower), the lower kept if it
// lowers that energy by more than 1e-6 relative. Returns the scales swept.
int hat_sweep(const CorrectionGrid& g, std::vector<double>& c);

// Global steps (docs/design.md §4.5.3c), without fixation. S: every
// movable node's energy gradient G (pinned nodes 0), plus, for every
// coarser lattice (every other node of the last, while a fixed axis keeps
// a free node and a periodic one halves evenly into at least 4), its full
// weighting (1, 1/2 per axis off centre; pinned nodes 0) interpolated
// bilinearly back (2 per node).
std::vector<double> multilevel_gradient(const CorrectionGrid& g, const std::vector<double>& c);
// The multilevel sum above of any field v (the steps' H0).
std::vector<double> multilevel_sum(const CorrectionGrid& g, std::vector<double> v);

// What a level's global steps remember: the last step's offsets x' and
// gradient G' (set by the first step tried), and whether the last step
// used their pair.
struct GlobalStepMemory {
    std::vector<double> x, G;
    bool used_pair = false;
};
// One step along -S: t from a probe at min(half the first flip of any
// triangle, 1 / max |S|) and the minimum of the parabola through E(0),
// E'(0) = -G.S and it (capped at 0.95 of the flip; then 1/8 and 1/64 of
// the probe while neither was lower), the lowest kept if it lowers the
// total energy by more than 1e-6 relative. Returns whether it moved.
// With `memory` holding the last step's x', G': S = H G, the memoryless
// BFGS update of H0 by s = c - x', y = G - G' (H G = H0 q + (a - b) s,
// q = G - a y, a = s.G / s.y, b = y.H0 q / s.y), used while s.y > 1e-8
// |s| |y| and G.S > 0, else S = H0 G; the memory then holds c, G.
bool global_step(const CorrectionGrid& g, std::vector<double>& c, GlobalStepMemory* memory = nullptr);

}  // namespace relief::reference
