// SPDX-License-Identifier: Apache-2.0
#pragma once
// One coarse-to-fine level of distortion correction on the device
// (docs/design.md §4.5; kernels/correct_nodes.cl): the node phases with tile
// skipping, interleaved with hat sweeps (hat_sweep.h) and global steps
// (global_step.h), until the tolerance. Used by correct_stage.cpp, which
// drives the levels.
#include <functional>
#include <utility>
#include <vector>

#include "correct/global_step.h"
#include "correct/hat_sweep.h"
#include "correct/level_state.h"

namespace relief::host {

inline constexpr int kTile = 16;  // nodes per tile side, CORRECT_TILE in correct.cl

class LevelSolver {
public:
    LevelSolver(ComputeContext& ctx, const NodeGrid& g, const std::vector<float>& z,
                const std::vector<float>& fix, const CorrectParams& p);

    // Offsets in texels of this level (float2 per node).
    void upload(const std::vector<float>& c) { state_.upload(c); }
    void download(std::vector<float>& c) { state_.download(c); }

    // Total energy; with `aniso` and `area`, per owned triangle (anisotropy,
    // area ratio).
    double energy(std::vector<float>* aniso = nullptr, std::vector<float>* area = nullptr)
    {
        return state_.energy_of(state_.offsets, aniso, area);
    }

    // Iterates; returns what happened.
    // on_iteration(it, rel): after iteration it, with the relative energy
    // change it made.
    // start_energy: the energy of the uploaded offsets when the caller has
    // it (else NaN); with measure_end false the caller measures the end
    // energy itself (energy_end is left NaN). predict_stop: the level may
    // also stop when the next iteration is predicted to fall below the
    // tolerance (FallHistory).
    CorrectLevel solve(const std::function<void(int, double)>& on_iteration, double tolerance,
                       double start_energy, bool measure_end, bool predict_stop);

private:
    // One pass of the node phases over the tiles that may move; counts
    // the tile phases run into `lv`.
    void node_phases(CorrectLevel& lv, std::vector<cl_uchar>& active);
    // Every tile runs the next phases (after moves of every node).
    void wake_all_tiles();

    LevelState state_;
    HatSweep hats_;
    GlobalStep global_;
    int nodes_per_item_;
    cl::Kernel phase_k_, active_k_;
    cl::NDRange phase_group_;  // of correct_phase: within one tile
    int tiles_x_ = 0, tiles_y_ = 0;
    std::vector<std::pair<int, int>> phases_;
    cl::Buffer moved_, active_;  // per tile and phase, per tile
};

}  // namespace relief::host
