// SPDX-License-Identifier: Apache-2.0
#pragma once
// One coarse-to-fine level of distortion correction on the device
// (docs/design.md §4.5; kernels/correct.cl): its buffers, the phases that
// move the nodes, the energy and gain reductions, tile skipping. Included
// only by correct_stage.cpp, which drives the levels.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "cancel.h"
#include "correct_grid.h"
#include "correct_stage.h"
#include "correct_stop_rule.h"
#include "errors.h"
#include "opencl_context.h"

namespace relief::host {

inline constexpr int kTile = 16;  // nodes per tile side, CORRECT_TILE in correct.cl
// Nodes per work-item of the energy and gain sums, CORRECT_SUM_NODES in
// correct.cl.
inline constexpr std::size_t kSumNodes = 8;
// Tolerances from this up follow the energy by the nodes' summed falls;
// tighter ones recompute the energy every iteration.
inline constexpr double kGainTolerance = 1e-6;
// Quads per work-item on CPUs (CORRECT_NODES: line searches in lockstep,
// to overlap their dependency chains). Measured on PoCL with Brent's search
// (1024^2, 12 iterations, 2 cores): 1 quad 1.28-1.33 s, 2 quads 1.07-1.28 s,
// 4 quads 1.10-1.36 s, 8 quads 1.07-1.17 s, so 2.
inline constexpr int kCpuNodesPerItem = 2;
// What a sweep of hat moves costs, in node iterations per scale of hats
// (measured on PoCL, 513^2 and 1025^2 nodes: 1.7 to 3.7, more for the
// larger scales). Deterministic, unlike a clock: the schedule must give
// the same bits on every run.
inline constexpr double kHatSweepCostPerScale = 2.5;
// What a global step costs, in node iterations (measured on PoCL at 1025^2
// nodes, iterations=20 at one level with and without steps: 0.50 on
// gk_castell_wall_v01, 0.49 on 0ad_desert_cliff; the gradient, the
// lattices down and up, the limits, the slope, two energies; 1.1 before
// their kernels took float8 lanes).
inline constexpr double kGlobalStepCost = 0.5;
// The least relative fall of the total energy that keeps a global step.
inline constexpr double kGlobalGain = 1e-6;
// A global step's quasi-Newton pair is used while s.y exceeds this times
// |s| |y| (the usual guard against a near-zero curvature).
inline constexpr double kQuasiCurvature = 1e-8;

// One level's device state and the kernels that work on it.
class LevelSolver {
public:
    LevelSolver(ComputeContext& ctx, const NodeGrid& g, const std::vector<float>& z,
                const std::vector<float>& fix, const CorrectParams& p)
        : c_(ctx.impl()), g_(g), p_(p), fp64_(ctx.fp64()),
          nodes_per_item_(ctx.device().is_gpu ? 1 : kCpuNodesPerItem), nodes_(std::size_t(g.nx) * g.ny),
          use_fix_(!fix.empty())
    {
        const bool whole = p.theta == std::floor(p.theta);
        cl::Program& prog =
            c_.program("correct.cl", std::string(fp64_ ? "-DRELIEF_FP64" : "") +
                                         (whole ? " -DCORRECT_ITHETA=" + std::to_string(int(p.theta)) : "") +
                                         " -DCORRECT_NODES=" + std::to_string(nodes_per_item_) +
                                         " -DCORRECT_SEARCH=" + std::to_string(int(p.search)));
        energy_k_ = cl::Kernel(prog, "correct_energy");
        phase_k_ = cl::Kernel(prog, "correct_phase");
        active_k_ = cl::Kernel(prog, "correct_active");
        gain_sum_k_ = cl::Kernel(prog, "correct_gain_sum");
        hat_k_ = cl::Kernel(prog, "correct_hat_phase");
        gradient_k_ = cl::Kernel(prog, "correct_gradient");
        restrict_k_ = cl::Kernel(prog, "correct_restrict");
        prolong_k_ = cl::Kernel(prog, "correct_prolong");
        limits_k_ = cl::Kernel(prog, "correct_step_limits");
        dot_k_ = cl::Kernel(prog, "correct_dot");
        step_k_ = cl::Kernel(prog, "correct_step");
        const std::size_t esize = fp64_ ? sizeof(double) : sizeof(float);
        // The sums' work-groups: powers of two from the device's limits, with
        // one energy_t of local memory per work-item.
        energy_group_ = c_.group_size(energy_k_, esize);
        phase_group_ = c_.group_shape(phase_k_, 8 / nodes_per_item_, 8);
        sum_group_ = c_.group_size(gain_sum_k_, esize);
        dot_group_ = c_.group_size(dot_k_, esize);
        groups_ = std::max({(nodes_ + kSumNodes * energy_group_ - 1) / (kSumNodes * energy_group_),
                            (nodes_ + kSumNodes * sum_group_ - 1) / (kSumNodes * sum_group_),
                            (nodes_ + kSumNodes * dot_group_ - 1) / (kSumNodes * dot_group_)});
        c_buf_ = c_.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * nodes_, "distortion correction");
        z_buf_ = c_.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * nodes_,
                           "distortion correction", z.data());
        fix_buf_ = use_fix_ ? c_.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * nodes_,
                                        "distortion correction", fix.data())
                            : c_.buffer(CL_MEM_READ_ONLY, sizeof(float), "distortion correction");
        partial_ = c_.buffer(CL_MEM_READ_WRITE, esize * groups_, "distortion correction");
        gain_ = c_.buffer(CL_MEM_READ_WRITE, esize * nodes_, "distortion correction");
        tiles_x_ = (g.nx + kTile - 1) / kTile;
        tiles_y_ = (g.ny + kTile - 1) / kTile;
        for (int cy = 0; cy < (g.periodic.y && (g.ny & 1) && g.ny > 1 ? 3 : 2); ++cy)
            for (int cx = 0; cx < (g.periodic.x && (g.nx & 1) && g.nx > 1 ? 3 : 2); ++cx)
                phases_.push_back({cx, cy});
        const std::size_t tiles = std::size_t(tiles_x_) * tiles_y_;
        moved_ = c_.buffer(CL_MEM_READ_WRITE, tiles * phases_.size(), "distortion correction");
        active_ = c_.buffer(CL_MEM_READ_WRITE, tiles, "distortion correction");
        // Hat moves leave fixation out of their energy, so they are off
        // with it; scales from B = 2 while both axes hold two hats a class
        // and the device lets a hat's work-item loop that long (llvmpipe
        // stops loops after about 65535 iterations: B <= 32 there).
        if (p.hats != CorrectParams::Hats::Off && !use_fix_)
            for (int B = 2; hat_axis_fits(g.nx, g.periodic.x, B) && hat_axis_fits(g.ny, g.periodic.y, B) &&
                            c_.loops_fit(hat_loops(B));
                 B *= 2)
                hat_scales_.push_back(B);
        // The global step's lattices: each every other node of the last,
        // while a fixed axis keeps a free node and a periodic one halves
        // evenly into at least 4. Global steps leave fixation out too.
        if (p.global != CorrectParams::Global::Off && !use_fix_) {
            global_ = true;
            int lx = g.nx, ly = g.ny;
            while (lattice_halves(lx, g.periodic.x) && lattice_halves(ly, g.periodic.y)) {
                lx = g.periodic.x ? lx / 2 : (lx - 1) / 2 + 1;
                ly = g.periodic.y ? ly / 2 : (ly - 1) / 2 + 1;
                lattices_.push_back({lx, ly});
            }
        }
    }

    // Offsets in texels of this level (float2 per node).
    void upload(const std::vector<float>& c)
    {
        c_.queue.enqueueWriteBuffer(c_buf_, CL_TRUE, 0, sizeof(cl_float2) * nodes_, c.data());
    }
    void download(std::vector<float>& c)
    {
        c.resize(2 * nodes_);
        c_.queue.enqueueReadBuffer(c_buf_, CL_TRUE, 0, sizeof(cl_float2) * nodes_, c.data());
    }

    // Total energy; with `stats`, per owned triangle (anisotropy, area ratio).
    // The statistics (16 bytes per node) come in chunks of at most one
    // device buffer; the partial sums are added in the same order whatever
    // the chunking.
    double energy(std::vector<float>* aniso = nullptr, std::vector<float>* area = nullptr)
    {
        return energy_of(c_buf_, aniso, area);
    }
    double energy_of(const cl::Buffer& offsets, std::vector<float>* aniso = nullptr,
                     std::vector<float>* area = nullptr)
    {
        const bool want = aniso != nullptr;
        const std::size_t esize = fp64_ ? sizeof(double) : sizeof(float);
        const std::size_t g = energy_group_, per_group = kSumNodes * g;
        std::size_t chunk = round_up(nodes_, per_group);
        if (want) {
            aniso->clear();
            area->clear();
            const std::size_t fit = c_.buffer_limit() / sizeof(cl_float4) / per_group * per_group;
            chunk = std::min(chunk, std::max(fit, per_group));
        }
        cl::Buffer stats = c_.buffer(CL_MEM_WRITE_ONLY, want ? sizeof(cl_float4) * chunk : 16,
                                     "distortion correction's statistics");
        // Room for every triangle up front (growing the vectors cost 13 ms
        // of a 1024^2 map's 30), so nothing reallocates or throws while the
        // buffer is mapped.
        if (want) {
            aniso->reserve(2 * nodes_);
            area->reserve(2 * nodes_);
        }
        double sum = 0.0;
        for (std::size_t first = 0; first < nodes_; first += chunk) {
            const std::size_t count = std::min(chunk, round_up(nodes_ - first, per_group));
            int a = 0;
            energy_k_.setArg(a++, offsets);
            energy_k_.setArg(a++, z_buf_);
            energy_k_.setArg(a++, fix_buf_);
            energy_k_.setArg(a++, cl_int(use_fix_));
            energy_k_.setArg(a++, cl_int(g_.nx));
            energy_k_.setArg(a++, cl_int(g_.ny));
            energy_k_.setArg(a++, cl_int(g_.periodic.bits()));
            energy_k_.setArg(a++, float(p_.theta));
            energy_k_.setArg(a++, partial_);
            energy_k_.setArg(a++, cl::Local(esize * g));
            energy_k_.setArg(a++, stats);
            energy_k_.setArg(a++, cl_int(want));
            energy_k_.setArg(a++, cl_int(first));
            stop_if_cancelled();
            c_.queue.enqueueNDRangeKernel(energy_k_, cl::NullRange, cl::NDRange(count / kSumNodes),
                                          cl::NDRange(g));
            add_partials(count / per_group, sum);
            if (want) {
                // Mapped, not read into a copy: a CPU device hands over its
                // own memory.
                const std::size_t real = std::min(count, nodes_ - first);
                const auto* st = static_cast<const float*>(
                    c_.queue.enqueueMapBuffer(stats, CL_TRUE, CL_MAP_READ, 0, sizeof(cl_float4) * real));
                for (std::size_t i = 0; i < 4 * real; i += 2)
                    if (!std::isnan(st[i])) {
                        aniso->push_back(st[i]);
                        area->push_back(st[i + 1]);
                    }
                c_.queue.enqueueUnmapMemObject(stats, const_cast<float*>(st));
            }
        }
        return sum;
    }

    // The energy fall of the last iteration: the sum of the nodes' gains.
    double gain_sum()
    {
        int a = 0;
        gain_sum_k_.setArg(a++, gain_);
        gain_sum_k_.setArg(a++, cl_int(nodes_));
        gain_sum_k_.setArg(a++, partial_);
        gain_sum_k_.setArg(a++, cl::Local((fp64_ ? sizeof(double) : sizeof(float)) * sum_group_));
        stop_if_cancelled();
        const std::size_t items = round_up((nodes_ + kSumNodes - 1) / kSumNodes, sum_group_);
        c_.queue.enqueueNDRangeKernel(gain_sum_k_, cl::NullRange, cl::NDRange(items),
                                      cl::NDRange(sum_group_));
        double sum = 0.0;
        add_partials(items / sum_group_, sum);
        return sum;
    }

    // Adds the first `groups` work-group partial sums to `sum`, in order.
    void add_partials(std::size_t groups, double& sum)
    {
        if (fp64_) {
            std::vector<double> part(groups);
            c_.queue.enqueueReadBuffer(partial_, CL_TRUE, 0, sizeof(double) * groups, part.data());
            for (double v : part)
                sum += v;
        } else {
            std::vector<float> part(groups);
            c_.queue.enqueueReadBuffer(partial_, CL_TRUE, 0, sizeof(float) * groups, part.data());
            for (float v : part)
                sum += v;
        }
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
                       double start_energy, bool measure_end, bool predict_stop)
    {
        CorrectLevel lv;
        lv.width = g_.width;
        lv.height = g_.height;
        const std::size_t tiles = std::size_t(tiles_x_) * tiles_y_;
        // Every tile runs the first time round.
        c_.fill(moved_, cl_uchar(1), 0, tiles * phases_.size());
        double e = std::isnan(start_energy) ? energy() : start_energy;
        lv.energy_start = e;
        std::vector<cl_uchar> act(tiles);
        const int limit = p_.iterations > 0 ? p_.iterations : p_.max_iterations;
        // Until the tolerance, max_iterations bounds a level's work: a hat
        // sweep counts as the node iterations it costs (the schedule's
        // price). Sweeps that did not count made a 4096^2 cliff level that
        // cannot converge 1.65x slower at the cap (22 sweeps of 11 scales on
        // top of its 1000 iterations). A fixed iterations=N counts node
        // iterations only.
        const double sweep_cost = kHatSweepCostPerScale * double(hat_scales_.size());
        int global_tries = 0;  // global steps tried, kept or not
        // Node iterations, hat sweeps and global steps in node iterations,
        // a step at `step` of one.
        const auto work = [&](double iterations, int sweeps, int steps, double step) {
            return iterations + sweeps * sweep_cost + steps * step;
        };
        const auto spent = [&](int it) {
            return p_.iterations > 0 ? double(it) : work(it, lv.hat_sweeps, global_tries, kGlobalStepCost);
        };
        // The energy falls by the sum of the nodes' falls (float fan
        // energies: exact to ~1e-7 of the energy); below that, a tolerance
        // needs the energy itself each iteration.
        const bool from_gains =
            !p_.energy_each_iteration && (p_.iterations > 0 || tolerance >= kGainTolerance);
        // The nodes' relative fall in the last iteration, and the last hat
        // sweep's (hat_sweep_due).
        double rel_nodes_before = 0.0, hat_fall = 0.0;
        double global_fall = 0.0;  // the last global step's relative fall
        FallHistory history;       // for the predicted stop
        for (int it = 1; it <= limit; ++it) {
            const int sweeps_before = lv.hat_sweeps, tries_before = global_tries;
            if (from_gains)
                clear_gains();
            for (std::size_t ph = 0; ph < phases_.size(); ++ph) {
                int a = 0;
                if (p_.skip_tiles) {
                    active_k_.setArg(a++, moved_);
                    active_k_.setArg(a++, cl_int(phases_.size()));
                    active_k_.setArg(a++, cl_int(tiles_x_));
                    active_k_.setArg(a++, cl_int(tiles_y_));
                    active_k_.setArg(a++, cl_int(g_.periodic.bits()));
                    active_k_.setArg(a++, active_);
                    c_.launch(active_k_, tiles);
                    c_.queue.enqueueReadBuffer(active_, CL_TRUE, 0, tiles, act.data());
                    for (cl_uchar v : act)
                        lv.tile_phases_run += v != 0;
                } else {
                    c_.fill(active_, cl_uchar(1), 0, tiles);
                    lv.tile_phases_run += tiles;
                }
                lv.tile_phases += tiles;
                c_.fill(moved_, cl_uchar(0), ph * tiles, tiles);
                a = 0;
                phase_k_.setArg(a++, c_buf_);
                phase_k_.setArg(a++, z_buf_);
                phase_k_.setArg(a++, fix_buf_);
                phase_k_.setArg(a++, cl_int(use_fix_));
                phase_k_.setArg(a++, cl_int(g_.nx));
                phase_k_.setArg(a++, cl_int(g_.ny));
                phase_k_.setArg(a++, cl_int(g_.periodic.bits()));
                phase_k_.setArg(a++, cl_int(phases_[ph].first));
                phase_k_.setArg(a++, cl_int(phases_[ph].second));
                phase_k_.setArg(a++, cl_int(tiles_x_));
                phase_k_.setArg(a++, active_);
                phase_k_.setArg(a++, moved_);
                phase_k_.setArg(a++, cl_int(ph * tiles));
                phase_k_.setArg(a++, float(p_.theta));
                phase_k_.setArg(a++, float(p_.relax));
                phase_k_.setArg(a++, gain_);
                // One tile is 8 / nodes_per_item x 8 work-items; the
                // kernel finds its tile from its global id, so the group
                // may be smaller where the device wants it so.
                stop_if_cancelled();
                c_.queue.enqueueNDRangeKernel(
                    phase_k_, cl::NullRange,
                    cl::NDRange(std::size_t(tiles_x_) * 8 / nodes_per_item_, std::size_t(tiles_y_) * 8),
                    phase_group_);
            }
            double next = from_gains ? e - gain_sum() : energy();
            const double rel_nodes = relative_fall(e, next);
            if (hat_sweep_due(lv.hat_sweeps, it, rel_nodes, rel_nodes_before, hat_fall, tolerance,
                              double(limit) - spent(it))) {
                const double before = next;
                if (from_gains)
                    clear_gains();
                hat_sweep();
                next = from_gains ? before - gain_sum() : energy();
                hat_fall = relative_fall(before, next);
                ++lv.hat_sweeps;
            }
            if (global_step_due(global_tries, rel_nodes, global_fall, tolerance, double(limit) - spent(it))) {
                const double before = next;
                ++global_tries;
                global_fall = 0.0;
                if (global_step(next)) {
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
            if (p_.iterations == 0 && std::isfinite(e) && std::isfinite(rel) &&
                (rel < tolerance || predicted)) {
                lv.converged = true;
                break;
            }
            if (spent(it) >= double(limit))
                break;
        }
        lv.energy_end = !measure_end ? std::numeric_limits<double>::quiet_NaN() : from_gains ? energy() : e;
        return lv;
    }

private:
    // The fall from `before` to `after` relative to `before`.
    static double relative_fall(double before, double after)
    {
        return (before - after) / std::max(std::abs(before), 1e-300);
    }

    // Whether an axis of n lattice nodes halves into another lattice (every
    // other node): a fixed axis while the coarser keeps a free node, a
    // periodic one while it halves evenly into at least 4.
    static bool lattice_halves(int n, bool periodic)
    {
        return periodic ? n % 2 == 0 && n / 2 >= 4 : (n - 1) / 2 + 1 >= 3;
    }

    // global=always: after every iteration. global=auto: after the first,
    // then whenever the last step fell more per cost than the nodes'
    // iteration did, and instead of stopping while it fell by more than the
    // tolerance per cost. `left` as for hat sweeps.
    bool global_step_due(int tries, double rel_nodes, double fall, double tolerance, double left) const
    {
        if (!global_ || !(rel_nodes >= 0.0))
            return false;
        if (p_.global == CorrectParams::Global::Always)
            return true;
        if (left < kGlobalStepCost)
            return false;
        if (tries == 0)
            return true;
        return fall > kGlobalStepCost * rel_nodes ||
               (rel_nodes < tolerance && fall >= kGlobalStepCost * tolerance);
    }

    // One global step (docs/design.md §4.5.3c; kernels correct_gradient to
    // correct_step): S, the multilevel sum of the gradient, then t along
    // D = -S by a probe at min(half the first flip, a texel's move) and the
    // parabola through E(0), E'(0) = -G.S and it (then 1/8 and 1/64 of the
    // probe while neither was lower), the lowest kept if it lowers the
    // total energy by more than 1e-6 relative. `energy`: the energy now,
    // exact or tracked by the nodes' falls (within ~1e-7 of it, far inside
    // the 1e-6 a step must gain, so the energy still never rises). Returns
    // whether the step was taken; `energy` is then the energy after it
    // (exact).
    bool global_step(double& energy)
    {
        const std::size_t esize = fp64_ ? sizeof(double) : sizeof(float);
        const std::size_t limits_group = c_.group_size(limits_k_, sizeof(cl_float2));
        // Eight nodes a work-item (correct_step_limits).
        const std::size_t limits_items = round_up((nodes_ + 7) / 8, limits_group);
        if (global_bufs_.empty()) {
            for (int k = 0; k < 3; ++k)  // the gradient, S, the offsets after a step
                global_bufs_.push_back(c_.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * nodes_,
                                                 "distortion correction's global steps"));
            for (const auto& l : lattices_)
                global_bufs_.push_back(c_.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * l.first * l.second,
                                                 "distortion correction's global steps"));
            limits_ = c_.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * (limits_items / limits_group),
                                "distortion correction's global steps");
            for (cl::Buffer* b : {&x_last_, &g_last_})
                *b = c_.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * nodes_,
                               "distortion correction's global steps");
        }
        cl::Buffer &grad = global_bufs_[0], &S = global_bufs_[1], &after = global_bufs_[2];
        const cl_int periodic = g_.periodic.bits();
        int a = 0;
        gradient_k_.setArg(a++, c_buf_);
        gradient_k_.setArg(a++, z_buf_);
        gradient_k_.setArg(a++, cl_int(g_.nx));
        gradient_k_.setArg(a++, cl_int(g_.ny));
        gradient_k_.setArg(a++, periodic);
        gradient_k_.setArg(a++, float(p_.theta));
        gradient_k_.setArg(a++, grad);
        stop_if_cancelled();
        c_.launch(gradient_k_, nodes_);
        // The multilevel sum of `in` (the preconditioner H0): down the
        // lattices by full weighting, then up, each lattice plus the
        // coarser one interpolated, the finest into S.
        const auto multilevel_sum = [&](const cl::Buffer& in) {
            const std::size_t L = lattices_.size();
            for (std::size_t l = 0; l < L; ++l) {
                const cl::Buffer& fine = l == 0 ? in : global_bufs_[3 + l - 1];
                const int fnx = l == 0 ? g_.nx : lattices_[l - 1].first,
                          fny = l == 0 ? g_.ny : lattices_[l - 1].second;
                a = 0;
                restrict_k_.setArg(a++, fine);
                restrict_k_.setArg(a++, cl_int(fnx));
                restrict_k_.setArg(a++, cl_int(fny));
                restrict_k_.setArg(a++, periodic);
                restrict_k_.setArg(a++, global_bufs_[3 + l]);
                restrict_k_.setArg(a++, cl_int(lattices_[l].first));
                restrict_k_.setArg(a++, cl_int(lattices_[l].second));
                c_.launch(restrict_k_, std::size_t(lattices_[l].first) * lattices_[l].second);
            }
            c_.queue.enqueueCopyBuffer(in, S, 0, 0, sizeof(cl_float2) * nodes_);
            for (std::size_t l = L; l-- > 0;) {
                // Lattice l interpolated into the next finer one (S at the end).
                cl::Buffer& fine = l == 0 ? S : global_bufs_[3 + l - 1];
                const int fnx = l == 0 ? g_.nx : lattices_[l - 1].first,
                          fny = l == 0 ? g_.ny : lattices_[l - 1].second;
                a = 0;
                prolong_k_.setArg(a++, global_bufs_[3 + l]);
                prolong_k_.setArg(a++, cl_int(lattices_[l].first));
                prolong_k_.setArg(a++, cl_int(lattices_[l].second));
                prolong_k_.setArg(a++, fine);
                prolong_k_.setArg(a++, cl_int(fnx));
                prolong_k_.setArg(a++, cl_int(fny));
                prolong_k_.setArg(a++, periodic);
                c_.launch(prolong_k_, std::size_t(fnx) * fny);
            }
        };
        const std::size_t dot_items = round_up((nodes_ + kSumNodes - 1) / kSumNodes, dot_group_);
        const auto dot = [&](const cl::Buffer& u, const cl::Buffer& v) {
            int k = 0;
            dot_k_.setArg(k++, u);
            dot_k_.setArg(k++, v);
            dot_k_.setArg(k++, cl_int(nodes_));
            dot_k_.setArg(k++, partial_);
            dot_k_.setArg(k++, cl::Local(esize * dot_group_));
            c_.queue.enqueueNDRangeKernel(dot_k_, cl::NullRange, cl::NDRange(dot_items),
                                          cl::NDRange(dot_group_));
            double sum = 0.0;
            add_partials(dot_items / dot_group_, sum);
            return sum;
        };
        const auto minus = [&](const cl::Buffer& u, const cl::Buffer& v, double t, cl::Buffer& out) {
            int k = 0;  // out = u - t v
            step_k_.setArg(k++, u);
            step_k_.setArg(k++, v);
            step_k_.setArg(k++, float(t));
            step_k_.setArg(k++, cl_int(nodes_));
            step_k_.setArg(k++, out);
            c_.launch(step_k_, nodes_);
        };
        const auto copy = [&](const cl::Buffer& from, cl::Buffer& to) {
            c_.queue.enqueueCopyBuffer(from, to, 0, 0, sizeof(cl_float2) * nodes_);
        };
        // S = H G, H the memoryless BFGS update of H0 by the pair s = x -
        // x', y = G - G' from the last global step tried (x' its offsets,
        // G' its gradient), kept while s.y > 1e-8 |s| |y| and H G descends;
        // else S = H0 G. The pair carries the curvature along the motion of
        // a whole iteration (the nodes' phases and the step): the smooth,
        // map-wide modes a cliff map's tail crawls along (docs/design.md
        // §4.5.3c). x' and G' become s and y in place, then the new x', G'.
        bool quasi = false;
        if (have_last_) {
            cl::Buffer &s = x_last_, &y = g_last_;
            minus(c_buf_, x_last_, 1.0, s);
            minus(grad, g_last_, 1.0, y);
            const double sy = dot(s, y), ss = dot(s, s), yy = dot(y, y);
            quasi = std::isfinite(sy) && std::isfinite(ss) && std::isfinite(yy) &&
                    sy > kQuasiCurvature * std::sqrt(ss * yy);
            if (quasi) {
                const double rho = 1.0 / sy, alpha = rho * dot(s, grad);
                minus(grad, y, alpha, after);  // q = G - alpha y
                multilevel_sum(after);
                const double beta = rho * dot(y, S);
                minus(S, s, beta - alpha, after);  // S = H0 q + (alpha - beta) s
                std::swap(S, after);
                const double gs = dot(grad, S);
                quasi = std::isfinite(alpha) && std::isfinite(beta) && std::isfinite(gs) && gs > 0.0;
            }
        }
        copy(c_buf_, x_last_);
        copy(grad, g_last_);
        have_last_ = true;
        if (!quasi)
            multilevel_sum(grad);
        // The first flip and the largest move along D, and the slope.
        a = 0;
        limits_k_.setArg(a++, c_buf_);
        limits_k_.setArg(a++, S);
        limits_k_.setArg(a++, cl_int(g_.nx));
        limits_k_.setArg(a++, cl_int(g_.ny));
        limits_k_.setArg(a++, periodic);
        limits_k_.setArg(a++, limits_);
        limits_k_.setArg(a++, cl::Local(sizeof(cl_float2) * limits_group));
        c_.queue.enqueueNDRangeKernel(limits_k_, cl::NullRange, cl::NDRange(limits_items),
                                      cl::NDRange(limits_group));
        std::vector<cl_float2> lim(limits_items / limits_group);
        c_.queue.enqueueReadBuffer(limits_, CL_TRUE, 0, sizeof(cl_float2) * lim.size(), lim.data());
        double flip = INFINITY, largest = 0.0;
        for (const auto& v : lim) {
            flip = std::min(flip, double(v.s[0]));
            largest = std::max(largest, double(v.s[1]));
        }
        const double slope = -dot(grad, S);
        if (!(slope < 0.0) || !std::isfinite(slope) || !(largest > 0.0) || !std::isfinite(largest) ||
            !(flip > 0.0))
            return false;
        // E(0) is the energy the caller tracks: one evaluation of the
        // three or more a step costs (4% of a 1024^2 wall's run).
        const double E0 = std::isfinite(energy) ? energy : this->energy();
        const auto offsets_at = [&](double t) { minus(c_buf_, S, t, after); };
        double best = E0, best_t = 0.0, last_t = 0.0;
        const auto probe_at = [&](double t) {
            offsets_at(t);
            last_t = t;
            const double e = energy_of(after);
            if (std::isfinite(e) && e < best) {
                best = e;
                best_t = t;
            }
            return e;
        };
        double probe = std::min(0.5 * flip, 1.0 / largest);
        for (int tries = 0; tries < 3 && best_t == 0.0; ++tries, probe *= 0.125) {
            const double ep = probe_at(probe);
            if (!std::isfinite(ep))
                continue;
            const double curvature = (ep - E0 - slope * probe) / (probe * probe);
            if (curvature > 0.0) {
                const double t = std::min(-slope / (2.0 * curvature), 0.95 * flip);
                if (t > 0.0 && t != probe)
                    probe_at(t);
            }
        }
        if (best_t == 0.0 || !(best < E0 - kGlobalGain * E0))
            return false;
        if (last_t != best_t)
            offsets_at(best_t);
        std::swap(c_buf_, after);
        // Every node may have moved: every tile runs the next phases.
        c_.fill(moved_, cl_uchar(1), 0, std::size_t(tiles_x_) * tiles_y_ * phases_.size());
        energy = best;
        return true;
    }

    void clear_gains()
    {
        if (fp64_)
            c_.fill(gain_, cl_double(0), 0, sizeof(double) * nodes_);
        else
            c_.fill(gain_, cl_float(0), 0, sizeof(float) * nodes_);
    }

    // The loop iterations of one hat's work-item at radius B: 2B rows of
    // 2B nodes, for the gradient, the bracket, E(0), up to six probes and
    // the move (each triangle's power is unrolled: RELIEF_DEFINE_POWN).
    static std::uint64_t hat_loops(int B) { return 10 * (4 * std::uint64_t(B) * B + 2 * std::uint64_t(B)); }

    // Whether an axis of n nodes holds hats of radius B, two a class: a
    // periodic axis needs whole pairs of hats round it.
    static bool hat_axis_fits(int n, bool periodic, int B)
    {
        return periodic ? n % (2 * B) == 0 && n >= 4 * B : n >= 2 * B + 1;
    }

    // hats=always: every iteration. hats=auto: the first sweep once the
    // nodes' falls, shrinking geometrically at their last rate, would take
    // longer than a sweep costs to reach the tolerance; then whenever an
    // iteration of the nodes gains less per cost than the last sweep did,
    // and instead of stopping while the last sweep gained more than the
    // tolerance per cost. Ordinary maps converge before the first. `left`:
    // the node iterations the level may still spend (max_iterations less
    // the iterations and sweeps so far); auto sweeps only while a sweep
    // fits in it.
    bool hat_sweep_due(int sweeps, int it, double rel_nodes, double rel_nodes_before, double hat_fall,
                       double tolerance, double left) const
    {
        if (hat_scales_.empty())
            return false;
        if (p_.hats == CorrectParams::Hats::Always)
            return true;
        const double cost = kHatSweepCostPerScale * double(hat_scales_.size());
        if (!(rel_nodes >= 0.0) || left < cost)
            return false;
        if (sweeps == 0) {
            if (it < 3 || rel_nodes < tolerance)
                return false;
            const double rate = rel_nodes_before > 0.0 ? rel_nodes / rel_nodes_before : 1.0;
            return rate >= 1.0 || std::log(tolerance / rel_nodes) / std::log(rate) > cost;
        }
        return rel_nodes * cost < hat_fall || (rel_nodes < tolerance && hat_fall >= cost * tolerance);
    }

    // One sweep: each scale B = 2, 4, ... (coarse error last, after the
    // fine moves it rests on), each class of hats in turn.
    void hat_sweep()
    {
        for (int B : hat_scales_) {
            const int hx = g_.periodic.x ? g_.nx / B : (g_.nx - 1) / B + 1;
            const int hy = g_.periodic.y ? g_.ny / B : (g_.ny - 1) / B + 1;
            for (int cy = 0; cy < 2; ++cy)
                for (int cx = 0; cx < 2; ++cx) {
                    const int count = ((hx - cx + 1) / 2) * ((hy - cy + 1) / 2);
                    if (count <= 0)
                        continue;
                    int a = 0;
                    hat_k_.setArg(a++, c_buf_);
                    hat_k_.setArg(a++, z_buf_);
                    hat_k_.setArg(a++, cl_int(g_.nx));
                    hat_k_.setArg(a++, cl_int(g_.ny));
                    hat_k_.setArg(a++, cl_int(g_.periodic.bits()));
                    hat_k_.setArg(a++, cl_int(B));
                    hat_k_.setArg(a++, cl_int(cx));
                    hat_k_.setArg(a++, cl_int(cy));
                    hat_k_.setArg(a++, cl_int(hx));
                    hat_k_.setArg(a++, cl_int(hy));
                    hat_k_.setArg(a++, float(p_.theta));
                    hat_k_.setArg(a++, gain_);
                    stop_if_cancelled();
                    c_.launch(hat_k_, std::size_t(count));
                }
        }
        // Every node may have moved: every tile runs the next phases.
        c_.fill(moved_, cl_uchar(1), 0, std::size_t(tiles_x_) * tiles_y_ * phases_.size());
    }

    ComputeContext::Impl& c_;
    NodeGrid g_;
    const CorrectParams& p_;
    bool fp64_;
    int nodes_per_item_;
    std::size_t nodes_;
    bool use_fix_;
    std::size_t groups_ = 0;        // partial sums the buffer holds
    std::size_t energy_group_ = 1;  // work-group of correct_energy
    std::size_t sum_group_ = 1;     // work-group of correct_gain_sum
    cl::Kernel hat_k_;
    cl::Kernel gradient_k_, restrict_k_, prolong_k_, limits_k_, dot_k_, step_k_;
    bool global_ = false;                        // global steps on
    std::vector<std::pair<int, int>> lattices_;  // the global step's coarser lattices, finest first
    std::vector<cl::Buffer> global_bufs_;        // gradient, S, offsets after a step, then the lattices
    cl::Buffer limits_;                          // per work-group: first flip, largest move
    // The last global step's offsets and gradient (its quasi-Newton pair's
    // x' and G'), once a step has been tried.
    cl::Buffer x_last_, g_last_;
    bool have_last_ = false;
    std::size_t dot_group_ = 1;    // work-group of correct_dot
    std::vector<int> hat_scales_;  // B of each scale of hat moves; empty: none
    cl::NDRange phase_group_;      // of correct_phase: within one tile
    int tiles_x_ = 0, tiles_y_ = 0;
    std::vector<std::pair<int, int>> phases_;
    cl::Kernel energy_k_, phase_k_, active_k_, gain_sum_k_;
    cl::Buffer c_buf_, z_buf_, fix_buf_, partial_, moved_, active_, gain_;
};

}  // namespace relief::host
