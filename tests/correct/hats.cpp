// SPDX-License-Identifier: Apache-2.0
// Distortion correction: hat moves (§4.5.3b) against the golden model, and when auto sweeps.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <utility>

#include "device/compute_context.h"
#include "correct/correct_grid.h"
#include "correct/correct_stage.h"
#include "correct/correct_stop_rule.h"
#include "reference/correct_reference.h"
#include "relief/correct.h"
#include "relief/errors.h"
#include "support/fields.h"
#include "support/images.h"
#include "correct/correct_test.h"

using namespace relief;
using namespace relief::test::correction;

TEST_CASE("correct: one device iteration with a hat sweep equals the golden model's", "[correct]")
{
    // hats=always at one iteration: the node phases, then every scale of
    // hat moves (radius 2, 4, 8 here), as the golden model's iterate() then
    // hat_sweep(). Steep waves, so that the hats move; one periodic axis
    // with the other fixed, and an odd fixed width.
    using P = host::Periodic;
    for (auto [w, h, periodic] : {std::tuple{32, 32, P(true)}, std::tuple{33, 25, P(false)},
                                  std::tuple{32, 21, P(true, false)}, std::tuple{19, 32, P(false, true)}}) {
        const auto hts = waves(w, h, 1.0, 21);
        const double scale = 1.0;
        auto [g, c, e_nodes] = after_node_iteration(hts, w, h, scale, periodic);
        const int scales = ref::hat_sweep(g, c);
        const double e_gold = ref::total_energy(g, c);
        auto p = one_iteration(params(scale, periodic));
        p.hats = host::CorrectParams::Hats::Always;
        host::CorrectReport rep;
        const auto out = run(hts, w, h, p, &rep);
        const auto [dev, worst, largest] = agreement(out, c, w, h);
        const double e_dev = ref::total_energy(g, dev);
        INFO(w << "x" << h << " periodic x " << periodic.x << " y " << periodic.y << ": " << scales
               << " scales; energy after the nodes " << e_nodes << ", after the hats " << e_gold
               << " (device " << e_dev << "); max |offset| " << largest << ", max |device - golden| "
               << worst);
        CHECK(scales >= 2);
        REQUIRE(rep.levels.size() == 1);
        CHECK(rep.levels[0].hat_sweeps == 1);
        CHECK(e_gold < e_nodes * (1.0 - 1e-3));  // the hats moved something
        CHECK(worst <= 2e-2 * largest);
        CHECK(std::abs(e_dev - e_gold) <= 1e-4 * e_gold);
    }
}

TEST_CASE("correct: the multilevel gradient is the sum over hats of every scale", "[correct]")
{
    // S = G + sum over scales B = 2, 4, ... and hats phi of that scale of
    // (phi . G) phi, written out directly: bilinear hats centred every B
    // nodes (not on a fixed border), zero at pinned nodes, periodic ones
    // the shorter way round. 17^2 fixed: B = 2, 4, 8; 16^2 periodic: B =
    // 2, 4 (a periodic lattice keeps at least 4 nodes).
    for (const bool periodic : {false, true}) {
        const int n = periodic ? 16 : 17;
        const auto hts = waves(n, n, 1.0, 25);
        const ref::CorrectionGrid g = centre_grid(hts, n, n, 0.5, host::Periodic(periodic));
        std::mt19937 rng(3);
        std::uniform_real_distribution<double> u(-0.2, 0.2);
        std::vector<double> c(2 * std::size_t(n) * n);
        for (auto& v : c)
            v = u(rng);
        const auto pinned = [&](int i, int j) {
            return !periodic && (i == 0 || j == 0 || i == n - 1 || j == n - 1);
        };
        std::vector<double> G(c.size(), 0.0), S(c.size(), 0.0);
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                if (!pinned(i, j)) {
                    const ref::Vec2 d = ref::fan_gradient(g, c, i, j);
                    G[2 * (j * n + i)] = S[2 * (j * n + i)] = d[0];
                    G[2 * (j * n + i) + 1] = S[2 * (j * n + i) + 1] = d[1];
                }
        int scales = 0;
        for (int B = 2; periodic ? n / B >= 4 : (n - 1) / B >= 2; B *= 2, ++scales) {
            const auto w = [&](int x, int centre) {
                int d = std::abs(x - centre);
                if (periodic)
                    d = std::min(d, n - d);
                return d < B ? 1.0 - double(d) / B : 0.0;
            };
            for (int cj = 0; cj < n; cj += B)
                for (int ci = 0; ci < n; ci += B) {
                    if (pinned(ci, cj))
                        continue;
                    double a[2] = {0.0, 0.0};
                    for (int j = 0; j < n; ++j)
                        for (int i = 0; i < n; ++i)
                            for (int d = 0; d < 2; ++d)
                                a[d] += (pinned(i, j) ? 0.0 : w(i, ci) * w(j, cj)) * G[2 * (j * n + i) + d];
                    for (int j = 0; j < n; ++j)
                        for (int i = 0; i < n; ++i)
                            for (int d = 0; d < 2; ++d)
                                S[2 * (j * n + i) + d] += (pinned(i, j) ? 0.0 : w(i, ci) * w(j, cj)) * a[d];
                }
        }
        const std::vector<double> got = ref::multilevel_gradient(g, c);
        INFO((periodic ? "periodic " : "fixed ") << n << ": " << scales << " scales");
        CHECK(scales == (periodic ? 2 : 3));
        double worst = 0.0, largest = 0.0;
        for (std::size_t k = 0; k < S.size(); ++k) {
            worst = std::max(worst, std::abs(got[k] - S[k]));
            largest = std::max(largest, std::abs(S[k]));
        }
        CHECK(largest > 0.0);
        CHECK(worst <= 1e-12 * largest);
    }
}

TEST_CASE("correct: hat moves never raise the energy", "[correct][slow][kernel]")
{
    const int w = 48, h = 40;
    const auto hts = waves(w, h, 1.0, 22);
    each_layout([&](bool corner, host::Periodic periodic) {
        double previous = INFINITY, first = 0.0;
        for (int it = 0; it <= 4; ++it) {
            auto p = single_level(2.0, periodic, corner, std::max(it, 1));
            p.hats = host::CorrectParams::Hats::Always;
            host::CorrectReport rep;
            const auto out = run(hts, w, h, p, &rep);
            const double e = it == 0 ? rep.energy_before : rep.energy_after;
            INFO("iteration " << it);
            REQUIRE(std::isfinite(e));  // no triangle flipped
            CHECK(e <= previous * (1.0 + 1e-7));
            CHECK(rep.levels[0].hat_sweeps == std::max(it, 1));
            if (it == 0)
                first = e;
            previous = e;
        }
        CHECK(previous < first * 0.9);
    });
}

// The schedule, not the kernels (which the case above runs on every
// boundary): on a second OpenCL implementation this is minutes of whole
// corrections for no kernel the fast tier does not run.
TEST_CASE("correct: auto sweeps only slowly converging levels", "[correct][slow]")
{
    // Auto: a steep map's levels sweep (and end lower than without), a
    // gentle one's converge before the first sweep would pay (at 128^2 a
    // sweep of five scales costs about 12 iterations), bit for bit as with
    // hats=off.
    const int n = 128;
    const auto big = waves(n, n, 1.0, 23);
    for (const auto& [scale, steep] : {std::pair{1.0, true}, std::pair{0.05, false}}) {
        INFO("scale " << scale);
        auto p = params(scale, host::Periodic(true));
        p.hats = host::CorrectParams::Hats::Auto;
        p.global = host::CorrectParams::Global::Off;
        host::CorrectReport with, without;
        const auto a = run(big, n, n, p, &with);
        p.hats = host::CorrectParams::Hats::Off;
        const auto b = run(big, n, n, p, &without);
        int sweeps = 0;
        std::string levels;
        for (std::size_t l = 0; l < with.levels.size(); ++l) {
            sweeps += with.levels[l].hat_sweeps;
            levels += std::to_string(with.levels[l].width) + ": " +
                      std::to_string(with.levels[l].iterations) + " iterations, " +
                      std::to_string(with.levels[l].hat_sweeps) + " sweeps, energy " +
                      std::to_string(with.levels[l].energy_end) +
                      " (without: " + std::to_string(without.levels[l].iterations) + ", " +
                      std::to_string(without.levels[l].energy_end) + "); ";
        }
        INFO(levels);
        for (const auto& l : without.levels)
            CHECK(l.hat_sweeps == 0);
        if (steep) {
            CHECK(sweeps > 0);
            CHECK(with.energy_after < without.energy_after);
        } else {
            CHECK(sweeps == 0);
            CHECK(a == b);
        }
    }
}
