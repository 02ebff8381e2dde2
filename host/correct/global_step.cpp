// SPDX-License-Identifier: Apache-2.0
#include "correct/global_step.h"

#include <algorithm>
#include <cmath>

#include "device/cancel.h"
#include "device/queue_wait.h"

namespace relief::host {

namespace {

// The least relative fall of the total energy that keeps a global step.
constexpr double kGlobalGain = 1e-6;
// A global step's quasi-Newton pair is used while s.y exceeds this times
// |s| |y| (the usual guard against a near-zero curvature).
constexpr double kQuasiCurvature = 1e-8;

// Whether an axis of n lattice nodes halves into another lattice (every
// other node): a fixed axis while the coarser keeps a free node, a
// periodic one while it halves evenly into at least 4.
bool lattice_halves(int n, bool periodic)
{
    return periodic ? n % 2 == 0 && n / 2 >= 4 : (n - 1) / 2 + 1 >= 3;
}

}  // namespace

GlobalStep::GlobalStep(LevelState& s) : s_(s)
{
    gradient_k_ = cl::Kernel(s.program, "correct_gradient");
    restrict_k_ = cl::Kernel(s.program, "correct_restrict");
    prolong_k_ = cl::Kernel(s.program, "correct_prolong");
    limits_k_ = cl::Kernel(s.program, "correct_step_limits");
    dot_k_ = cl::Kernel(s.program, "correct_dot");
    step_k_ = cl::Kernel(s.program, "correct_step");
    dot_group_ = s.sum_group(dot_k_);
    // The lattices: each every other node of the last, while a fixed axis
    // keeps a free node and a periodic one halves evenly into at least 4.
    if (s.p.global != CorrectParams::Global::Off && !s.use_fix) {
        on_ = true;
        const NodeGrid& g = s.g;
        int lx = g.nx, ly = g.ny;
        while (lattice_halves(lx, g.periodic.x) && lattice_halves(ly, g.periodic.y)) {
            lx = g.periodic.x ? lx / 2 : (lx - 1) / 2 + 1;
            ly = g.periodic.y ? ly / 2 : (ly - 1) / 2 + 1;
            lattices_.push_back({lx, ly});
        }
    }
}

bool GlobalStep::due(int tries, double rel_nodes, double fall, double tolerance, double left) const
{
    if (!on_ || !(rel_nodes >= 0.0))
        return false;
    if (s_.p.global == CorrectParams::Global::Always)
        return true;
    if (left < kGlobalStepCost)
        return false;
    if (tries == 0)
        return true;
    return fall > kGlobalStepCost * rel_nodes ||
           (rel_nodes < tolerance && fall >= kGlobalStepCost * tolerance);
}

void GlobalStep::allocate()
{
    const std::size_t nodes = s_.nodes;
    const std::size_t limits_group = s_.c.group_size(limits_k_, sizeof(cl_float2));
    const std::size_t limits_items = round_up((nodes + 7) / 8, limits_group);
    for (int k = 0; k < 3; ++k)  // the gradient, S, the offsets after a step
        bufs_.push_back(s_.c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * nodes,
                                    "distortion correction's global steps"));
    for (const auto& l : lattices_)
        bufs_.push_back(s_.c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * l.first * l.second,
                                    "distortion correction's global steps"));
    limits_ = s_.c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * (limits_items / limits_group),
                          "distortion correction's global steps");
    for (cl::Buffer* b : {&x_last_, &g_last_})
        *b =
            s_.c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * nodes, "distortion correction's global steps");
    const std::size_t dot_items = round_up((nodes + kSumNodes - 1) / kSumNodes, dot_group_);
    dot_partial_ = s_.c.buffer(CL_MEM_READ_WRITE, s_.sum_size() * (dot_items / dot_group_),
                               "distortion correction's global steps");
}

// Down the lattices by full weighting, then up, each lattice plus the
// coarser one interpolated, the finest into S.
void GlobalStep::multilevel_sum(const cl::Buffer& in)
{
    const NodeGrid& g = s_.g;
    const cl_int periodic = g.periodic.bits();
    cl::Buffer& S = bufs_[1];
    const std::size_t L = lattices_.size();
    for (std::size_t l = 0; l < L; ++l) {
        const cl::Buffer& fine = l == 0 ? in : bufs_[3 + l - 1];
        const int fnx = l == 0 ? g.nx : lattices_[l - 1].first, fny = l == 0 ? g.ny : lattices_[l - 1].second;
        set_args(restrict_k_, fine, cl_int(fnx), cl_int(fny), periodic, bufs_[3 + l],
                 cl_int(lattices_[l].first), cl_int(lattices_[l].second));
        s_.c.launch(restrict_k_, std::size_t(lattices_[l].first) * lattices_[l].second);
    }
    s_.c.queue.enqueueCopyBuffer(in, S, 0, 0, sizeof(cl_float2) * s_.nodes);
    for (std::size_t l = L; l-- > 0;) {
        // Lattice l interpolated into the next finer one (S at the end).
        cl::Buffer& fine = l == 0 ? S : bufs_[3 + l - 1];
        const int fnx = l == 0 ? g.nx : lattices_[l - 1].first, fny = l == 0 ? g.ny : lattices_[l - 1].second;
        set_args(prolong_k_, bufs_[3 + l], cl_int(lattices_[l].first), cl_int(lattices_[l].second), fine,
                 cl_int(fnx), cl_int(fny), periodic);
        s_.c.launch(prolong_k_, std::size_t(fnx) * fny);
    }
}

double GlobalStep::dot(const cl::Buffer& u, const cl::Buffer& v)
{
    const std::size_t items = round_up((s_.nodes + kSumNodes - 1) / kSumNodes, dot_group_);
    set_args(dot_k_, u, v, cl_int(s_.nodes), dot_partial_, cl::Local(s_.sum_size() * dot_group_));
    s_.c.queue.enqueueNDRangeKernel(dot_k_, cl::NullRange, cl::NDRange(items), cl::NDRange(dot_group_));
    double sum = 0.0;
    s_.add_partials(dot_partial_, items / dot_group_, sum);
    return sum;
}

void GlobalStep::minus(const cl::Buffer& u, const cl::Buffer& v, double t, cl::Buffer& out)
{
    set_args(step_k_, u, v, float(t), cl_int(s_.nodes), out);
    s_.c.launch(step_k_, s_.nodes);
}

// S = H G, H the memoryless BFGS update of H0 by the pair s = x - x', y =
// G - G' from the last global step tried (x' its offsets, G' its
// gradient), kept while s.y > 1e-8 |s| |y| and H G descends. The pair
// carries the curvature along the motion of a whole iteration (the nodes'
// phases and the step): the smooth, map-wide modes a cliff map's tail
// crawls along (docs/design.md §4.5.3c). x' and G' become s and y in place.
bool GlobalStep::quasi_newton_direction(const cl::Buffer& grad)
{
    if (!have_last_)
        return false;
    cl::Buffer &S = bufs_[1], &after = bufs_[2];
    cl::Buffer &s = x_last_, &y = g_last_;
    minus(s_.offsets, x_last_, 1.0, s);
    minus(grad, g_last_, 1.0, y);
    const double sy = dot(s, y), ss = dot(s, s), yy = dot(y, y);
    bool quasi = std::isfinite(sy) && std::isfinite(ss) && std::isfinite(yy) &&
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
    return quasi;
}

std::pair<double, double> GlobalStep::limits()
{
    const NodeGrid& g = s_.g;
    const std::size_t group = s_.c.group_size(limits_k_, sizeof(cl_float2));
    // Eight nodes a work-item (correct_step_limits).
    const std::size_t items = round_up((s_.nodes + 7) / 8, group);
    set_args(limits_k_, s_.offsets, bufs_[1], cl_int(g.nx), cl_int(g.ny), cl_int(g.periodic.bits()), limits_,
             cl::Local(sizeof(cl_float2) * group));
    s_.c.queue.enqueueNDRangeKernel(limits_k_, cl::NullRange, cl::NDRange(items), cl::NDRange(group));
    std::vector<cl_float2> lim(items / group);
    read_asking(s_.c.queue, limits_, 0, sizeof(cl_float2) * lim.size(), lim.data());
    double flip = INFINITY, largest = 0.0;
    for (const auto& v : lim) {
        flip = std::min(flip, double(v.s[0]));
        largest = std::max(largest, double(v.s[1]));
    }
    return {flip, largest};
}

bool GlobalStep::step(double& energy)
{
    if (bufs_.empty())
        allocate();
    const NodeGrid& g = s_.g;
    cl::Buffer& grad = bufs_[0];
    set_args(gradient_k_, s_.offsets, s_.z, cl_int(g.nx), cl_int(g.ny), cl_int(g.periodic.bits()),
             float(s_.p.theta), grad);
    stop_if_cancelled();
    s_.c.launch(gradient_k_, s_.nodes);
    const bool quasi = quasi_newton_direction(grad);
    s_.c.queue.enqueueCopyBuffer(s_.offsets, x_last_, 0, 0, sizeof(cl_float2) * s_.nodes);
    s_.c.queue.enqueueCopyBuffer(grad, g_last_, 0, 0, sizeof(cl_float2) * s_.nodes);
    have_last_ = true;
    if (!quasi)
        multilevel_sum(grad);
    cl::Buffer &S = bufs_[1], &after = bufs_[2];
    // The first flip and the largest move along D, and the slope.
    const auto [flip, largest] = limits();
    const double slope = -dot(grad, S);
    if (!(slope < 0.0) || !std::isfinite(slope) || !(largest > 0.0) || !std::isfinite(largest) ||
        !(flip > 0.0))
        return false;
    // E(0) is the energy the caller tracks: one evaluation of the three or
    // more a step costs (4% of a 1024^2 wall's run).
    const double E0 = std::isfinite(energy) ? energy : s_.energy_of(s_.offsets);
    const auto offsets_at = [&](double t) { minus(s_.offsets, S, t, after); };
    double best = E0, best_t = 0.0, last_t = 0.0;
    const auto probe_at = [&](double t) {
        offsets_at(t);
        last_t = t;
        const double e = s_.energy_of(after);
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
    std::swap(s_.offsets, after);
    energy = best;
    return true;
}

}  // namespace relief::host
