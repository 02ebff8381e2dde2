// SPDX-License-Identifier: Apache-2.0
#pragma once
// Global steps (docs/design.md §4.5.3c; kernels/correct_global.cl): every
// node of a level at once along the multilevel-preconditioned negative
// gradient, quasi-Newton from a level's second step on. The coarser
// lattices, the buffers, when a step is due and the step.
#include <utility>
#include <vector>

#include "correct/level_state.h"

namespace relief::host {

// What a global step costs, in node iterations (measured on PoCL at 1025^2
// nodes, iterations=20 at one level with and without steps: 0.50 on
// gk_castell_wall_v01, 0.49 on 0ad_desert_cliff; the gradient, the
// lattices down and up, the limits, the slope, two energies; 1.1 before
// their kernels took float8 lanes).
inline constexpr double kGlobalStepCost = 0.5;

class GlobalStep {
public:
    // Off (never due) with global=off or fixation: global steps leave
    // fixation out of their energy.
    explicit GlobalStep(LevelState& s);

    // global=always: after every iteration. global=auto: after the first,
    // then whenever the last step fell more per cost than the nodes'
    // iteration did, and instead of stopping while it fell by more than the
    // tolerance per cost. `left`: the node iterations the level may still
    // spend.
    bool due(int tries, double rel_nodes, double fall, double tolerance, double left) const;

    // One step: S, the multilevel sum of the gradient (quasi-Newton from
    // the second), then t along D = -S by a probe at min(half the first
    // flip, a texel's move) and the parabola through E(0), E'(0) = -G.S and
    // it (then 1/8 and 1/64 of the probe while neither was lower), the
    // lowest kept if it lowers the total energy by more than 1e-6
    // relative. `energy`: the energy now, exact or tracked by the nodes'
    // falls (within ~1e-7 of it, far inside the 1e-6 a step must gain, so
    // the energy still never rises). Returns whether the step was taken;
    // `energy` is then the energy after it (exact) and every node may have
    // moved.
    bool step(double& energy);

private:
    // S = the multilevel sum of `in` (the preconditioner H0).
    void multilevel_sum(const cl::Buffer& in);
    double dot(const cl::Buffer& u, const cl::Buffer& v);
    // out = u - t v.
    void minus(const cl::Buffer& u, const cl::Buffer& v, double t, cl::Buffer& out);
    // S = H G (quasi-Newton) where the pair from the last step allows it;
    // whether it did.
    bool quasi_newton_direction(const cl::Buffer& grad);
    // The largest t before the first flip along -S, and the largest move.
    std::pair<double, double> limits();
    void allocate();

    LevelState& s_;
    bool on_ = false;
    cl::Kernel gradient_k_, restrict_k_, prolong_k_, limits_k_, dot_k_, step_k_;
    std::size_t dot_group_ = 1;
    std::vector<std::pair<int, int>> lattices_;  // the coarser lattices, finest first
    // The gradient, S, the offsets after a step, then the lattices.
    std::vector<cl::Buffer> bufs_;
    cl::Buffer limits_;       // per work-group: first flip, largest move
    cl::Buffer dot_partial_;  // per work-group of a dot product
    // The last step's offsets and gradient (its quasi-Newton pair's x' and
    // G'), once a step has been tried.
    cl::Buffer x_last_, g_last_;
    bool have_last_ = false;
};

}  // namespace relief::host
