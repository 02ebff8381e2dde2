// SPDX-License-Identifier: Apache-2.0
// Distortion correction: coarse to fine: where each level starts.
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

// The golden model's start of a periodic w x h level (centre nodes) from
// the coarser level's cw x ch offsets: those upsampled times 1, 0.75, 0.5,
// 0.25 or 0, whichever has the lowest energy. Returns {energy, factor}.
std::pair<double, double> golden_start(const std::vector<float>& hts, int w, int h, double scale,
                                       const std::vector<float>& coarse, int cw, int ch)
{
    const host::NodeGrid from(cw, ch, false, host::Periodic(true)), to(w, h, false, host::Periodic(true));
    const auto up = host::upsample_offsets(coarse, from, to);
    const auto g = centre_grid(hts, w, h, scale, true);
    double best = ref::total_energy(g, std::vector<double>(2 * std::size_t(w) * h, 0.0)), factor = 0.0;
    for (double f : {1.0, 0.75, 0.5, 0.25}) {
        std::vector<double> c(up.size());
        for (std::size_t i = 0; i < up.size(); i += 2) {
            c[i] = double(float(f * double(up[i]) * w));
            c[i + 1] = double(float(f * double(up[i + 1]) * h));
        }
        const double e = ref::total_energy(g, c);
        if (std::isfinite(e) && e < best) {
            best = e;
            factor = f;
        }
    }
    return {best, factor};
}

// The pyramid's coarsest level run alone, as the pyramid runs it: one
// level, to the tolerance itself (only the finest level stops on a
// predicted fall).
std::vector<float> coarsest_alone(const std::vector<float>& hts, int w, int h, int cw, int ch,
                                  host::CorrectParams p)
{
    p.levels = 1;
    p.predict_stop = false;
    return run(host::area_downsample(hts, w, h, cw, ch), cw, ch, p);
}

// A periodic correction of `levels` levels at `scale`, and its coarsest
// level (cw x ch) run alone; `iterations` a level (0: to the tolerance).
struct PyramidRun {
    host::CorrectReport report;
    std::vector<float> coarsest;
};
PyramidRun pyramid_run(const std::vector<float>& hts, int w, int h, double scale, int levels, int cw, int ch,
                       int iterations = 0)
{
    auto p = params(scale, true);
    p.levels = levels;
    p.iterations = iterations;
    PyramidRun r;
    run(hts, w, h, p, &r.report);
    REQUIRE(r.report.levels.size() == std::size_t(levels));
    r.coarsest = coarsest_alone(hts, w, h, cw, ch, p);
    return r;
}

}  // namespace

TEST_CASE("correct: a level starts from the scaled coarse offsets of lowest energy", "[correct]")
{
    // Steep waves: at the finer level their slopes in texels double, and the
    // coarse offsets, whole, can crowd them. The level starts from those
    // offsets times 1, 0.75, 0.5, 0.25 or 0, whichever has the lowest energy
    // (computed here by the golden model from the coarse level's result).
    const int w = 64, h = 48, cw = 32, ch = 24;
    const auto hts = waves(w, h, 1.0, 15);
    // Where a level starts needs the coarser level's offsets, not their
    // convergence: 60 iterations a level at scales 0.3 and 10 (which start
    // from 1 and 0.75; unbounded, scale 10 takes 771 at the finest level, a
    // minute on a driver whose launches are slow, Rusticl's). Scale 3 runs
    // to the tolerance: the start there is 0.5, which no capped run chose.
    const double scale = GENERATE(0.3, 3.0, 10.0);
    INFO("scale " << scale);
    const auto [rep, coarse] = pyramid_run(hts, w, h, scale, 2, cw, ch, scale == 3.0 ? 0 : 60);
    const auto [best, factor] = golden_start(hts, w, h, scale, coarse, cw, ch);
    const auto& fine = rep.levels.back();
    CHECK(fine.start_factor == factor);
    CHECK(fine.energy_start == Approx(best).epsilon(1e-5));
    // ... and the solve starts from those offsets: the energy only falls.
    CHECK(fine.energy_end <= fine.energy_start);
    CHECK(rep.levels.front().start_factor == 0.0);  // the coarsest starts at zero
}

// The schedule's arithmetic (its kernels are the fast tier's): not in the
// slow kernel tests that CI runs on a second OpenCL implementation.
TEST_CASE("correct: a level above the finest measures its own start", "[correct][slow]")
{
    // Three levels (128x96, 64x48, 32x24): the finest takes its zero-offset
    // energy from the one measured before the solve, the middle level must
    // measure its own. Its start: the coarsest level's offsets times 1,
    // 0.75, 0.5, 0.25 or 0, whichever has the lowest energy (the golden
    // model's: 1 at scale 1, 0.75 at scale 10).
    const int w = 128, h = 96, mw = 64, mh = 48, cw = 32, ch = 24;
    const auto hts = waves(w, h, 1.0, 15);
    const double scale = GENERATE(1.0, 10.0);
    INFO("scale " << scale);
    const auto [rep, coarse] = pyramid_run(hts, w, h, scale, 3, cw, ch);
    const auto [best, factor] =
        golden_start(host::area_downsample(hts, w, h, mw, mh), mw, mh, scale, coarse, cw, ch);
    const auto& mid = rep.levels[1];
    CHECK(mid.start_factor == factor);
    CHECK(mid.energy_start == Approx(best).epsilon(1e-5));
}
