// SPDX-License-Identifier: Apache-2.0
#pragma once
// Hat moves (docs/design.md §4.5.3b; kernels/correct_hats.cl's
// correct_hat_phase): regions of nodes moved together under bilinear hats
// of every scale B = 2, 4, ..., where the nodes alone converge slowly.
// One level's scales, when a sweep is due and the sweep itself.
#include <cstdint>
#include <vector>

#include "correct/level_state.h"

namespace relief::host {

class HatSweep {
public:
    // No scales (never due) with hats=off or fixation: hat moves leave
    // fixation out of their energy.
    explicit HatSweep(LevelState& s);

    // What a sweep costs, in node iterations: a price per scale of hats,
    // deterministic (unlike a clock) so that the schedule gives the same
    // bits on every run.
    double cost() const;

    // hats=always: every iteration. hats=auto: the first sweep once the
    // nodes' falls, shrinking geometrically at their last rate, would take
    // longer than a sweep costs to reach the tolerance; then whenever an
    // iteration of the nodes gains less per cost than the last sweep did,
    // and instead of stopping while the last sweep gained more than the
    // tolerance per cost. Ordinary maps converge before the first. `left`:
    // the node iterations the level may still spend (max_iterations less
    // the iterations and sweeps so far); auto sweeps only while a sweep
    // fits in it.
    bool due(int sweeps, int it, double rel_nodes, double rel_nodes_before, double hat_fall, double tolerance,
             double left) const;

    // One sweep: each scale (coarse error last, after the fine moves it
    // rests on), each class of hats in turn. The nodes' falls add to the
    // level's gains; every node may have moved.
    void sweep();

private:
    LevelState& s_;
    cl::Kernel hat_k_;
    std::vector<int> scales_;  // B of each scale of hat moves; empty: none
};

}  // namespace relief::host
