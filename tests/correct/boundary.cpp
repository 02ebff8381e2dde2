// SPDX-License-Identifier: Apache-2.0
// Distortion correction: boundary=auto, the wrap seams' jumps against the mean jump.
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

TEST_CASE("correct: boundary=auto on a map one texel wide or tall is fixed (a seam needs two texels)",
          "[correct][boundary]")
{
    for (const auto& [w, h] : {std::pair<int, int>{1, 12}, {12, 1}, {1, 1}}) {
        INFO(w << "x" << h);
        std::vector<float> ramp(std::size_t(w) * h);
        for (std::size_t i = 0; i < ramp.size(); ++i)
            ramp[i] = 0.25f * float(i % 3);
        CorrectOptions o;
        o.scale = 0.1f;
        OIIO::ImageBuf offsets = correct(test::image(w, h, 1, ramp), o);
        REQUIRE_FALSE(offsets.has_error());
        CHECK(offsets.spec().get_string_attribute("relief:boundary") == "fixed");
    }
}

TEST_CASE("correct: boundary=auto weighs the jump across each wrap seam against the mean jump between "
          "neighbours, per axis",
          "[correct]")
{
    // -v says the two ratios; an axis is periodic when its ratio is at most 2.
    const auto decide = [](const std::vector<float>& px, int w, int h) {
        relief::CorrectOptions o;
        o.scale = 0.05f;
        o.levels = 1;
        o.iterations = 1;
        std::string said;
        o.exec.on_message = [&](relief::Severity, const std::string& m) {
            if (m.rfind("correct: boundary", 0) == 0)
                said = m;
        };
        OIIO::ImageBuf out;
        REQUIRE(relief::correct(out, relief::test::image(w, h, 1, px), o));
        return said;
    };
    // a ramp along x (0..7), constant along y: x's seam jumps 7, its
    // neighbours 1; y has no jumps at all (ratio 1 by definition)
    const int w = 8, h = 5;
    std::vector<float> ramp(std::size_t(w) * h), rows(std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            ramp[std::size_t(y) * w + x] = float(x);
            rows[std::size_t(y) * w + x] = float(y);
        }
    CHECK_THAT(decide(ramp, w, h),
               Catch::StartsWith("correct: boundary fixed,periodic (") && Catch::Contains("x 7.00, y 1.00;"));
    CHECK_THAT(decide(rows, w, h),
               Catch::StartsWith("correct: boundary periodic,fixed (") && Catch::Contains("x 1.00, y 4.00;"));
    // a gentle periodic bump, jumps far below a texel: it tiles
    const int n = 32;
    std::vector<float> bump(std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            bump[std::size_t(y) * n + x] =
                float(0.05 * std::sin(2 * M_PI * x / n) * std::cos(2 * M_PI * (y + 0.5) / n));
    CHECK_THAT(decide(bump, n, n), Catch::StartsWith("correct: boundary periodic ("));
    // one texel off a flat map, at (0, 0): each axis's seam and its
    // neighbours carry one jump of 1 each, over h (w) seam pairs against
    // (w - 1) h ((h - 1) w) neighbour pairs: ratios w - 1 and h - 1
    std::vector<float> dot(std::size_t(w) * h, 0.0f);
    dot[0] = 1.0f;
    CHECK_THAT(decide(dot, w, h),
               Catch::StartsWith("correct: boundary fixed (") && Catch::Contains("x 7.00, y 4.00;"));
    CHECK_THAT(decide(std::vector<float>(std::size_t(w) * h, 3.0f), w, h),
               Catch::StartsWith("correct: boundary periodic (") && Catch::Contains("x 1.00, y 1.00;"));
}
