// SPDX-License-Identifier: Apache-2.0
#include "correct/level_solver.h"

#include <cmath>
#include <limits>

#include "correct/correct_stop_rule.h"
#include "device/cancel.h"
#include "device/queue_wait.h"

namespace relief::host {

namespace {

// Tolerances from this up follow the energy by the nodes' summed falls;
// tighter ones recompute the energy every iteration.
constexpr double kGainTolerance = 1e-6;
// Quads per work-item on CPUs (CORRECT_NODES: line searches in lockstep,
// to overlap their dependency chains). Measured on PoCL with Brent's search
// (1024^2, 12 iterations, 2 cores): 1 quad 1.28-1.33 s, 2 quads 1.07-1.28 s,
// 4 quads 1.10-1.36 s, 8 quads 1.07-1.17 s, so 2.
constexpr int kCpuNodesPerItem = 2;

int nodes_per_item(ComputeContext& ctx)
{
    return ctx.device().is_gpu ? 1 : kCpuNodesPerItem;
}

// The fall from `before` to `after` relative to `before`.
double relative_fall(double before, double after)
{
    return (before - after) / std::max(std::abs(before), 1e-300);
}

}  // namespace

LevelSolver::LevelSolver(ComputeContext& ctx, const NodeGrid& g, const std::vector<float>& z,
                         const std::vector<float>& fix, const CorrectParams& p)
    : state_(ctx, g, z, fix, p, nodes_per_item(ctx)), hats_(state_), global_(state_),
      nodes_per_item_(nodes_per_item(ctx))
{
    phase_k_ = cl::Kernel(state_.program, "correct_phase");
    active_k_ = cl::Kernel(state_.program, "correct_active");
    phase_group_ = state_.c.group_shape(phase_k_, 8 / nodes_per_item_, 8);
    tiles_x_ = (g.nx + kTile - 1) / kTile;
    tiles_y_ = (g.ny + kTile - 1) / kTile;
    for (int cy = 0; cy < (g.periodic.y && (g.ny & 1) && g.ny > 1 ? 3 : 2); ++cy)
        for (int cx = 0; cx < (g.periodic.x && (g.nx & 1) && g.nx > 1 ? 3 : 2); ++cx)
            phases_.push_back({cx, cy});
    const std::size_t tiles = std::size_t(tiles_x_) * tiles_y_;
    moved_ = state_.c.buffer(CL_MEM_READ_WRITE, tiles * phases_.size(), "distortion correction");
    active_ = state_.c.buffer(CL_MEM_READ_WRITE, tiles, "distortion correction");
}

void LevelSolver::wake_all_tiles()
{
    state_.c.fill(moved_, cl_uchar(1), 0, std::size_t(tiles_x_) * tiles_y_ * phases_.size());
}

void LevelSolver::node_phases(CorrectLevel& lv, std::vector<cl_uchar>& act)
{
    auto& c = state_.c;
    const NodeGrid& g = state_.g;
    const CorrectParams& p = state_.p;
    const std::size_t tiles = std::size_t(tiles_x_) * tiles_y_;
    for (std::size_t ph = 0; ph < phases_.size(); ++ph) {
        if (p.skip_tiles) {
            set_args(active_k_, moved_, cl_int(phases_.size()), cl_int(tiles_x_), cl_int(tiles_y_),
                     cl_int(g.periodic.bits()), active_);
            c.launch(active_k_, tiles);
            state_.read_each_iteration(active_, tiles, act.data());
            for (cl_uchar v : act)
                lv.tile_phases_run += v != 0;
        } else {
            c.fill(active_, cl_uchar(1), 0, tiles);
            lv.tile_phases_run += tiles;
        }
        lv.tile_phases += tiles;
        c.fill(moved_, cl_uchar(0), ph * tiles, tiles);
        set_args(phase_k_, state_.offsets, state_.z, state_.fix, cl_int(state_.use_fix), cl_int(g.nx),
                 cl_int(g.ny), cl_int(g.periodic.bits()), cl_int(phases_[ph].first),
                 cl_int(phases_[ph].second), cl_int(tiles_x_), active_, moved_, cl_int(ph * tiles),
                 float(p.theta), float(p.relax), state_.gain);
        // One tile is 8 / nodes_per_item x 8 work-items; the kernel finds
        // its tile from its global id, so the group may be smaller where
        // the device wants it so.
        stop_if_cancelled();
        c.queue.enqueueNDRangeKernel(
            phase_k_, cl::NullRange,
            cl::NDRange(std::size_t(tiles_x_) * 8 / nodes_per_item_, std::size_t(tiles_y_) * 8),
            phase_group_);
    }
}

CorrectLevel LevelSolver::solve(const std::function<void(int, double)>& on_iteration, double tolerance,
                                double start_energy, bool measure_end, bool predict_stop)
{
    const CorrectParams& p = state_.p;
    CorrectLevel lv;
    lv.width = state_.g.width;
    lv.height = state_.g.height;
    // Every tile runs the first time round.
    wake_all_tiles();
    double e = std::isnan(start_energy) ? energy() : start_energy;
    lv.energy_start = e;
    std::vector<cl_uchar> act(std::size_t(tiles_x_) * tiles_y_);
    const int limit = p.iterations > 0 ? p.iterations : p.max_iterations;
    // Until the tolerance, max_iterations bounds a level's work: a hat
    // sweep counts as the node iterations it costs (the schedule's
    // price). Sweeps that did not count made a 4096^2 cliff level that
    // cannot converge 1.65x slower at the cap (22 sweeps of 11 scales on
    // top of its 1000 iterations). A fixed iterations=N counts node
    // iterations only.
    const double sweep_cost = hats_.cost();
    int global_tries = 0;  // global steps tried, kept or not
    // Node iterations, hat sweeps and global steps in node iterations,
    // a step at `step` of one.
    const auto work = [&](double iterations, int sweeps, int steps, double step) {
        return iterations + sweeps * sweep_cost + steps * step;
    };
    const auto spent = [&](int it) {
        return p.iterations > 0 ? double(it) : work(it, lv.hat_sweeps, global_tries, kGlobalStepCost);
    };
    // The energy falls by the sum of the nodes' falls (float fan
    // energies: exact to ~1e-7 of the energy); below that, a tolerance
    // needs the energy itself each iteration.
    const bool from_gains = !p.energy_each_iteration && (p.iterations > 0 || tolerance >= kGainTolerance);
    // The nodes' relative fall in the last iteration, and the last hat
    // sweep's (HatSweep::due).
    double rel_nodes_before = 0.0, hat_fall = 0.0;
    double global_fall = 0.0;  // the last global step's relative fall
    FallHistory history;       // for the predicted stop
    for (int it = 1; it <= limit; ++it) {
        const int sweeps_before = lv.hat_sweeps, tries_before = global_tries;
        if (from_gains)
            state_.clear_gains();
        node_phases(lv, act);
        double next = from_gains ? e - state_.gain_sum() : energy();
        const double rel_nodes = relative_fall(e, next);
        if (hats_.due(lv.hat_sweeps, it, rel_nodes, rel_nodes_before, hat_fall, tolerance,
                      double(limit) - spent(it))) {
            const double before = next;
            if (from_gains)
                state_.clear_gains();
            hats_.sweep();
            wake_all_tiles();
            next = from_gains ? before - state_.gain_sum() : energy();
            hat_fall = relative_fall(before, next);
            ++lv.hat_sweeps;
        }
        if (global_.due(global_tries, rel_nodes, global_fall, tolerance, double(limit) - spent(it))) {
            const double before = next;
            ++global_tries;
            global_fall = 0.0;
            if (global_.step(next)) {
                wake_all_tiles();
                global_fall = relative_fall(before, next);
                ++lv.global_steps;
            }
        }
        rel_nodes_before = rel_nodes;
        // The tolerance bounds the fall per pass over the nodes: the
        // node phases are one, a global step tried another (it moves
        // every node too), a hat sweep counts as the iterations it
        // costs. Counted in moves, not seconds, so that the rule is the
        // same on every device.
        const double passes = work(1.0, lv.hat_sweeps - sweeps_before, global_tries - tries_before, 1.0);
        const double rel = relative_fall(e, next) / passes;
        e = next;
        lv.iterations = it;
        if (on_iteration)
            on_iteration(it, rel);
        history.push(rel, passes);
        const bool predicted = predict_stop && history.predicts_below(tolerance);
        // An infinite energy (a flipped start, or one beyond the
        // device's range without fp64) is never "converged".
        if (p.iterations == 0 && std::isfinite(e) && std::isfinite(rel) && (rel < tolerance || predicted)) {
            lv.converged = true;
            break;
        }
        if (spent(it) >= double(limit))
            break;
    }
    lv.energy_end = !measure_end ? std::numeric_limits<double>::quiet_NaN() : from_gains ? energy() : e;
    return lv;
}

}  // namespace relief::host
