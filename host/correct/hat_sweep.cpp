// SPDX-License-Identifier: Apache-2.0
#include "correct/hat_sweep.h"

#include <cmath>

#include "device/cancel.h"

namespace relief::host {

namespace {

// What a sweep of hat moves costs, in node iterations per scale of hats
// (measured on PoCL, 513^2 and 1025^2 nodes: 1.7 to 3.7, more for the
// larger scales).
constexpr double kHatSweepCostPerScale = 2.5;

// The loop iterations of one hat's work-item at radius B: 2B rows of
// 2B nodes, for the gradient, the bracket, E(0), up to six probes and
// the move (each triangle's power is unrolled: RELIEF_DEFINE_POWN).
std::uint64_t hat_loops(int B)
{
    return 10 * (4 * std::uint64_t(B) * B + 2 * std::uint64_t(B));
}

// Whether an axis of n nodes holds hats of radius B, two a class: a
// periodic axis needs whole pairs of hats round it.
bool hat_axis_fits(int n, bool periodic, int B)
{
    return periodic ? n % (2 * B) == 0 && n >= 4 * B : n >= 2 * B + 1;
}

}  // namespace

HatSweep::HatSweep(LevelState& s) : s_(s)
{
    hat_k_ = cl::Kernel(s.program, "correct_hat_phase");
    // Scales from B = 2 while both axes hold two hats a class and the
    // device lets a hat's work-item loop that long (llvmpipe stops loops
    // after about 65535 iterations: B <= 32 there).
    const NodeGrid& g = s.g;
    if (s.p.hats != CorrectParams::Hats::Off && !s.use_fix)
        for (int B = 2; hat_axis_fits(g.nx, g.periodic.x, B) && hat_axis_fits(g.ny, g.periodic.y, B) &&
                        s.c.loops_fit(hat_loops(B));
             B *= 2)
            scales_.push_back(B);
}

double HatSweep::cost() const
{
    return kHatSweepCostPerScale * double(scales_.size());
}

bool HatSweep::due(int sweeps, int it, double rel_nodes, double rel_nodes_before, double hat_fall,
                   double tolerance, double left) const
{
    if (scales_.empty())
        return false;
    if (s_.p.hats == CorrectParams::Hats::Always)
        return true;
    const double cost = this->cost();
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

void HatSweep::sweep()
{
    const NodeGrid& g = s_.g;
    for (int B : scales_) {
        const int hx = g.periodic.x ? g.nx / B : (g.nx - 1) / B + 1;
        const int hy = g.periodic.y ? g.ny / B : (g.ny - 1) / B + 1;
        for (int cy = 0; cy < 2; ++cy)
            for (int cx = 0; cx < 2; ++cx) {
                const int count = ((hx - cx + 1) / 2) * ((hy - cy + 1) / 2);
                if (count <= 0)
                    continue;
                set_args(hat_k_, s_.offsets, s_.z, cl_int(g.nx), cl_int(g.ny), cl_int(g.periodic.bits()),
                         cl_int(B), cl_int(cx), cl_int(cy), cl_int(hx), cl_int(hy), float(s_.p.theta),
                         s_.gain);
                stop_if_cancelled();
                s_.c.launch(hat_k_, std::size_t(count));
            }
    }
}

}  // namespace relief::host
