// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the distortion correction's tests share: the golden model's grid,
// the host parameters of one iteration, a run, and how closely the device
// follows the golden model.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "correct/correct_stage.h"
#include "device/compute_context.h"
#include "reference/correct_reference.h"

namespace relief::test::correction {

using relief::test::waves;

namespace ref = relief::reference;

// The golden model's grid for centre nodes (heights in texels).
inline ref::CorrectionGrid centre_grid(const std::vector<float>& h, int w, int ht, double scale,
                                       host::Periodic periodic, double theta = 5.0)
{
    ref::CorrectionGrid g;
    g.nx = w;
    g.ny = ht;
    g.periodic_x = periodic.x;
    g.periodic_y = periodic.y;
    g.theta = theta;
    for (float v : h)
        g.z.push_back(double(v) * scale * w);
    return g;
}

inline host::CorrectParams params(double scale, host::Periodic periodic, bool corner = false)
{
    host::CorrectParams p;
    p.scale = scale;
    p.periodic = periodic;
    p.corner_nodes = corner;
    return p;
}

// Exactly one iteration at a single resolution, every tile run, nothing
// skipped as too flat: what the golden model's iterate() does.
inline host::CorrectParams one_iteration(host::CorrectParams p)
{
    p.levels = 1;
    p.iterations = 1;
    p.skip_tiles = false;
    p.threshold = 0.0;
    p.polish = 0;
    return p;
}

inline std::vector<float> run(const std::vector<float>& h, int w, int ht, const host::CorrectParams& p,
                              host::CorrectReport* rep = nullptr)
{
    auto ctx = host::ComputeContext::acquire("auto");
    std::vector<float> out(2 * std::size_t(w) * ht);
    host::correct_distortion(*ctx, h.data(), w, ht, p, out.data(), rep);
    return out;
}

// The device's offsets (texture units) in texels, and how far they lie from
// the golden model's c: the largest difference and the largest offset.
struct Agreement {
    std::vector<double> device;
    double worst = 0.0, largest = 0.0;
};
inline Agreement agreement(const std::vector<float>& out, const std::vector<double>& c, int w, int h)
{
    Agreement a;
    a.device.resize(c.size());
    for (std::size_t k = 0; k < c.size(); ++k) {
        a.device[k] = double(out[k]) * (k % 2 ? h : w);
        a.worst = std::max(a.worst, std::abs(a.device[k] - c[k]));
        a.largest = std::max(a.largest, std::abs(c[k]));
    }
    return a;
}

// `iterations` iterations at one level, every triangle counted (threshold
// 0): the runs of the tests that the energy never rises.
inline host::CorrectParams single_level(double scale, host::Periodic periodic, bool corner, int iterations)
{
    auto p = params(scale, periodic, corner);
    p.levels = 1;
    p.iterations = iterations;
    p.threshold = 0.0;
    return p;
}

// The boundaries those tests run every node kind on: periodic, fixed, mixed.
inline const host::Periodic kBoundaries[] = {host::Periodic(true), host::Periodic(false),
                                             host::Periodic(false, true)};

// Calls f(corner, periodic) for both node kinds and every boundary of
// kBoundaries, each named in a failure's message.
template <class F>
void each_layout(F&& f)
{
    for (bool corner : {false, true})
        for (const host::Periodic periodic : kBoundaries) {
            INFO("corner " << corner << " periodic x " << periodic.x << " y " << periodic.y);
            f(corner, periodic);
        }
}

// The golden model's centre-node grid for `hts`, its offsets after one
// iteration of the nodes from zero, and the energy then: where the
// comparisons of one device iteration with a hat sweep or a global step
// start.
struct AfterNodes {
    ref::CorrectionGrid grid;
    std::vector<double> c;
    double energy = 0.0;
};
inline AfterNodes after_node_iteration(const std::vector<float>& hts, int w, int h, double scale,
                                       host::Periodic periodic)
{
    AfterNodes a{centre_grid(hts, w, h, scale, periodic), std::vector<double>(2 * std::size_t(w) * h, 0.0)};
    ref::iterate(a.grid, a.c);
    a.energy = ref::total_energy(a.grid, a.c);
    return a;
}

}  // namespace relief::test::correction
