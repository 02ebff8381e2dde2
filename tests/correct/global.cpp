// SPDX-License-Identifier: Apache-2.0
// Distortion correction: global steps (§4.5.3c), plain and quasi-Newton, against the
// golden model, and when auto steps.
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

namespace {

using P = host::Periodic;

// The grids a device's global steps are compared with the golden model's
// on: periodic, fixed (an odd width) and mixed axes; steep waves at scale
// 0.5, so that the steps move.
struct StepGrid {
    int w, h;
    P periodic;
    std::vector<float> heights() const { return waves(w, h, 1.0, 24); }
};
const StepGrid kStepGrids[] = {
    {32, 32, P(true)}, {33, 25, P(false)}, {32, 21, P(true, false)}, {40, 32, P(false, true)}};
constexpr double kStepScale = 0.5;

// `iterations` node iterations at one level, each followed by a global step.
host::CorrectParams global_always(P periodic, int iterations)
{
    auto p = one_iteration(params(kStepScale, periodic));
    p.iterations = iterations;
    p.hats = host::CorrectParams::Hats::Off;
    p.global = host::CorrectParams::Global::Always;
    return p;
}

}  // namespace

namespace {

// global=always at one iteration: the node phases, then one step along the
// multilevel gradient, as the golden model's iterate() then global_step().
void check_global_step(const std::vector<float>& hts, int w, int h, P periodic)
{
    auto [g, c, e_nodes] = after_node_iteration(hts, w, h, kStepScale, periodic);
    const bool moved = ref::global_step(g, c);
    const double e_gold = ref::total_energy(g, c);
    host::CorrectReport rep;
    const auto out = run(hts, w, h, global_always(periodic, 1), &rep);
    const auto [dev, worst, largest] = agreement(out, c, w, h);
    const double e_dev = ref::total_energy(g, dev);
    INFO(w << "x" << h << " periodic x " << periodic.x << " y " << periodic.y << ": energy after the nodes "
           << e_nodes << ", after the step " << e_gold << " (device " << e_dev << "); max |offset| "
           << largest << ", max |device - golden| " << worst);
    CHECK(moved);
    CHECK(e_gold < e_nodes * (1.0 - 1e-4));  // the step lowered the energy
    REQUIRE(rep.levels.size() == 1);
    CHECK(rep.levels[0].global_steps == 1);
    CHECK(worst <= 2e-2 * largest);
    CHECK(std::abs(e_dev - e_gold) <= 1e-4 * e_gold);
}

}  // namespace

TEST_CASE("correct: one device iteration with a global step equals the golden model's", "[correct]")
{
    for (const auto& [w, h, periodic] : kStepGrids)
        check_global_step(StepGrid{w, h, periodic}.heights(), w, h, periodic);
}

TEST_CASE("correct: a global step's first flip and largest move count the last nodes", "[correct]")
{
    // 8 x 257 = 2056 nodes, eight a work-item: 257 items, so the limits'
    // last work-group (of 256, 128 or 64 items) holds the last row alone.
    // Fixed borders and waves only near the bottom: the triangles that
    // row owns (towards the row above it, which moves) are among the first
    // to flip. A step whose limits left that group out goes too far.
    const int w = 8, h = 257;
    std::vector<float> hts(std::size_t(w) * h, 0.0f);
    for (int y = 241; y < h; ++y)
        for (int x = 0; x < w; ++x)
            hts[std::size_t(y) * w + x] = float(std::sin(0.9 * x + 0.3 * y) * (y - 240) / 16.0);
    check_global_step(hts, w, h, P(false));
}

TEST_CASE("correct: a level's second global step is quasi-Newton, as the golden model's", "[correct]")
{
    // global=always at two iterations: the second step's direction is the
    // memoryless BFGS update of the multilevel sum by the pair (s, y) from
    // the first step's offsets and gradient (the golden model's
    // GlobalStepMemory). Without the pair the second step differs.
    for (const auto& [w, h, periodic] : kStepGrids) {
        const auto hts = StepGrid{w, h, periodic}.heights();
        ref::CorrectionGrid g = centre_grid(hts, w, h, kStepScale, periodic);
        std::vector<double> c(2 * std::size_t(w) * h, 0.0);
        ref::GlobalStepMemory memory;
        ref::iterate(g, c);
        const bool first = ref::global_step(g, c, &memory);
        ref::iterate(g, c);
        std::vector<double> plain = c;
        ref::global_step(g, plain);
        const bool second = ref::global_step(g, c, &memory);
        const double e_gold = ref::total_energy(g, c), e_plain = ref::total_energy(g, plain);
        host::CorrectReport rep;
        const auto out = run(hts, w, h, global_always(periodic, 2), &rep);
        const auto [dev, worst, largest] = agreement(out, c, w, h);
        const auto plain_gap = agreement(out, plain, w, h).worst;
        const double e_dev = ref::total_energy(g, dev);
        INFO(w << "x" << h << " periodic x " << periodic.x << " y " << periodic.y
               << ": energy after the steps " << e_gold << " (device " << e_dev << ", a plain second step "
               << e_plain << "); max |offset| " << largest << ", max |device - golden| " << worst
               << ", from the plain step's " << plain_gap);
        CHECK(first);
        CHECK(second);
        CHECK(memory.used_pair);
        REQUIRE(rep.levels.size() == 1);
        CHECK(rep.levels[0].global_steps == 2);
        CHECK(worst <= 2e-2 * largest);
        // The plain step lands elsewhere (by 0.4% to 3.5% of the largest
        // offset, 5e-4 to 2e-3 of the energy): the device took the pair.
        CHECK(worst < plain_gap);
        CHECK(std::abs(e_dev - e_gold) < 0.5 * std::abs(e_plain - e_gold));
        CHECK(std::abs(e_dev - e_gold) <= 1e-4 * e_gold);
    }
}

TEST_CASE("correct: global steps never raise the energy, and auto ends lower than without", "[correct]")
{
    const int w = 48, h = 40;
    const auto hts = waves(w, h, 1.0, 26);
    each_layout([&](bool corner, host::Periodic periodic) {
        double previous = INFINITY;
        for (int it = 1; it <= 4; ++it) {
            auto p = single_level(0.5, periodic, corner, it);
            p.hats = host::CorrectParams::Hats::Off;
            p.global = host::CorrectParams::Global::Always;
            host::CorrectReport rep;
            run(hts, w, h, p, &rep);
            INFO("iterations " << it << ": energy " << rep.energy_after << ", steps "
                               << rep.levels[0].global_steps);
            REQUIRE(std::isfinite(rep.energy_after));  // no triangle flipped
            CHECK(rep.energy_after <= previous * (1.0 + 1e-7));
            CHECK(rep.levels[0].global_steps >= 1);
            previous = rep.energy_after;
        }
    });
    // Auto, to the tolerance on the whole pyramid: lower than without.
    const int n = 128;
    const auto big = waves(n, n, 1.0, 27);
    auto p = params(0.05, host::Periodic(true));
    host::CorrectReport with, without;
    run(big, n, n, p, &with);
    p.global = host::CorrectParams::Global::Off;
    run(big, n, n, p, &without);
    int steps = 0;
    for (const auto& l : with.levels)
        steps += l.global_steps;
    for (const auto& l : without.levels)
        CHECK(l.global_steps == 0);
    INFO("energy with " << with.energy_after << " (" << steps << " steps), without " << without.energy_after);
    CHECK(steps > 0);
    CHECK(with.energy_after < without.energy_after);
}
