// SPDX-License-Identifier: Apache-2.0
// The bake's options reach the gather.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iterator>
#include <functional>
#include <random>

#include "bake/bake_stage.h"
#include "device/compute_context.h"
#include "correct/correct_stage.h"
#include "device/memory_budget.h"
#include "poisson/poisson_stage.h"
#include "rays/rays_stage.h"
#include "relief/relief.h"
#include "slopes/slope_stage.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/option_cases.h"

using namespace relief;
using namespace relief::test::options;

TEST_CASE("options: bake filter and wrap reach the gather", "[options][bake]")
{
    const int w = 21, h = 17, nch = 2;
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), d(-0.08f, 0.08f);
    std::vector<float> src(std::size_t(w) * h * nch), off(2 * std::size_t(w) * h);
    for (float& v : src)
        v = u(rng);
    for (float& v : off)
        v = d(rng);
    const ImageBuf tex = test::image(w, h, nch, src), offsets = test::image(w, h, 2, off);
    auto ctx = host::ComputeContext::acquire("auto");
    std::vector<std::vector<float>> results;
    for (bool periodic : {false, true})
        for (bool bicubic : {false, true}) {
            INFO("periodic " << periodic << " bicubic " << bicubic);
            BakeOptions o;
            o.colorspace = BakeColorspace::Raw;
            o.filter = bicubic ? BakeFilter::Bicubic : BakeFilter::Bilinear;
            o.wrap = periodic ? BakeWrap::Periodic : BakeWrap::Clamp;
            ImageBuf out = relief::bake(tex, offsets, o);
            REQUIRE_FALSE(out.has_error());
            std::vector<float> want(src.size());
            host::bake_gather(*ctx, src.data(), w, h, nch, off.data(), periodic,
                              bicubic ? host::BakeFilter::Bicubic : host::BakeFilter::Bilinear, want.data());
            CHECK(pixels(out) == want);
            results.push_back(want);
        }
    for (std::size_t a = 0; a < results.size(); ++a)
        for (std::size_t b = a + 1; b < results.size(); ++b)
            CHECK(max_abs_diff(results[a], results[b]) > 1e-3);
}
