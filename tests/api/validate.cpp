// SPDX-License-Identifier: Apache-2.0
// The API refuses inconsistent or out-of-range options, and a failed call's
// image carries the error.
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

namespace {

// An option set wrongly, and the words its refusal must hold.
template <class Options>
struct Refusal {
    const char* what;
    std::function<void(Options&)> set;
    const char* message;
};

// Each refusal's options, from `base`, give `run`'s error (which must name
// `operation` first) with the refusal's words in it.
template <class Options, std::size_t N, class Run>
void check_refusals(const Refusal<Options> (&refusals)[N], const Options& base, const std::string& operation,
                    Run run)
{
    for (const Refusal<Options>& c : refusals) {
        INFO(c.what);
        Options o = base;
        c.set(o);
        const std::string e = run(o);
        INFO(e);
        CHECK(e.find(c.message) != std::string::npos);
        CHECK(e.rfind(operation + ": ", 0) == 0);
    }
}

}  // namespace

TEST_CASE("options: inconsistent or out-of-range options are refused by the API", "[options][errors]")
{
    const int w = 48, h = 40;
    const auto g = tiling_slopes(w, h, 8);
    const ImageBuf normals = test::normal_image(g, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    auto height_error = [&](const HeightOptions& o) {
        ImageBuf out;
        return relief::height(out, normals, o) ? std::string("accepted") : relief::geterror();
    };
    const ImageBuf short_mask = test::image(w, h - 1, 1, std::vector<float>(std::size_t(w) * (h - 1), 0.5f));
    const ImageBuf narrow_mask = test::image(w - 1, h, 1, std::vector<float>(std::size_t(w - 1) * h, 0.5f));
    const ImageBuf half_mask = test::image(w, h, 1, std::vector<float>(std::size_t(w) * h, 0.5f));
    std::vector<float> bad_values(std::size_t(w) * h, 0.5f);
    bad_values[17] = 1.5f;
    const ImageBuf over_mask = test::image(w, h, 1, bad_values);
    const Refusal<HeightOptions> hcases[] = {
        {"mask one row short", [&](HeightOptions& o) { o.mask = &short_mask; }, "the mask is 48x39"},
        {"mask one column short", [&](HeightOptions& o) { o.mask = &narrow_mask; }, "the mask is 47x40"},
        {"mask value above 1", [&](HeightOptions& o) { o.mask = &over_mask; },
         "mask values must be in [0, 1]"},
        {"mask and rays",
         [&](HeightOptions& o) {
             o.mask = &half_mask;
             o.method = HeightMethod::Rays;
         },
         "mask applies to method=poisson"},
        {"mask and highpass",
         [&](HeightOptions& o) {
             o.mask = &half_mask;
             o.highpass = 8;
         },
         "highpass cannot be combined with a mask"},
        {"alpha mask and highpass",
         [&](HeightOptions& o) {
             o.mask_alpha = true;
             o.highpass = 8;
         },
         "highpass cannot be combined with a mask"},
        {"highpass and rays",
         [&](HeightOptions& o) {
             o.highpass = 8;
             o.method = HeightMethod::Rays;
         },
         "highpass applies to method=poisson"},
        {"phase 1", [](HeightOptions& o) { o.phase = 1.0f; },
         "phase=1 is out of range; it must be in [0, 1)"},
        {"phase negative", [](HeightOptions& o) { o.phase = -0.25f; },
         "phase=-0.25 is out of range; it must be in [0, 1)"},
        {"radius too large", [](HeightOptions& o) { o.radius = 70000.0f; }, "radius"},
        {"max_angle 90", [](HeightOptions& o) { o.normals.max_angle = 90.0f; },
         "max_angle=90 is out of range; it must be in (0, 90) degrees"},
        {"max_angle 0", [](HeightOptions& o) { o.normals.max_angle = 0.0f; }, "max_angle=0 is out of range"},
        {"fast with exact directions",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.directions = RayDirections::Exact;
         },
         "impl=fast needs directions=rational"},
    };
    HeightOptions opengl;
    opengl.normals.convention = NormalConvention::OpenGL;
    check_refusals(hcases, opengl, "height", height_error);

    const int cw = 40, ch = 36;
    const ImageBuf height = test::image(cw, ch, 1, waves(cw, ch, 1.0, 4));
    const ImageBuf tall_fix =
        test::image(cw, ch + 1, 1, std::vector<float>(std::size_t(cw) * (ch + 1), 1.0f));
    const ImageBuf wide_fix = test::image(cw + 1, ch, 1, std::vector<float>(std::size_t(cw + 1) * ch, 1.0f));
    std::vector<float> negative(std::size_t(cw) * ch, 1.0f);
    negative[5] = -1.0f;
    const ImageBuf negative_fix = test::image(cw, ch, 1, negative);
    const Refusal<CorrectOptions> ccases[] = {
        {"fixation mask one row long", [&](CorrectOptions& o) { o.fix_mask = &tall_fix; },
         "the fixation mask is 40x37, the height map 40x36"},
        {"fixation mask one column wide", [&](CorrectOptions& o) { o.fix_mask = &wide_fix; },
         "the fixation mask is 41x36"},
        {"negative fixation weight", [&](CorrectOptions& o) { o.fix_mask = &negative_fix; },
         "fixation weights must be finite and >= 0"},
        {"mask and tent",
         [&](CorrectOptions& o) {
             o.fix_mask = &wide_fix;
             o.fix_width = 1;
         },
         "not both"},
        {"theta above 20", [](CorrectOptions& o) { o.theta = 20.5f; },
         "theta=20.5 is out of range; it must be in [0, 20]"},
        {"tolerance 0", [](CorrectOptions& o) { o.tolerance = 0.0f; },
         "tolerance=0 is out of range; it must be in (0, 1)"},
        {"negative threshold", [](CorrectOptions& o) { o.threshold = -1.0f; },
         "threshold=-1 is out of range; it must be in [0, 1e+09]"},
        {"polish above 1000", [](CorrectOptions& o) { o.polish = 1001; },
         "polish=1001 must be an integer in [0, 1000]"},
        {"negative levels", [](CorrectOptions& o) { o.levels = -1; },
         "levels=-1 must be an integer in [1, 30] or auto"},
        {"NaN scale", [](CorrectOptions& o) { o.scale = std::nanf(""); }, "scale=nan is not a number"},
    };
    CorrectOptions scaled;
    scaled.scale = 0.3f;
    check_refusals(ccases, scaled, "correct", [&](const CorrectOptions& o) {
        ImageBuf out;
        CHECK_FALSE(relief::correct(out, height, o));
        return relief::geterror();
    });
}

TEST_CASE("options: a failed call's returned image carries the error", "[options][errors]")
{
    const ImageBuf gray(OIIO::ImageSpec(8, 8, 1, TypeDesc::FLOAT));
    const ImageBuf s = relief::slopes(gray);
    CHECK(s.has_error());
    CHECK(s.geterror().find("slopes: unsupported channel count 1") != std::string::npos);
    const ImageBuf h = relief::height(gray);
    CHECK(h.has_error());
    CHECK(h.geterror().find("height: unsupported channel count 1") != std::string::npos);
    CorrectOptions co;
    co.scale = -1.0f;
    const ImageBuf c = relief::correct(gray, co);
    CHECK(c.has_error());
    CHECK(c.geterror().find("correct: scale=-1 is out of range; it must be in (0, 1e+09] or auto") !=
          std::string::npos);
    const ImageBuf b = relief::bake(gray, gray);
    CHECK(b.has_error());
    CHECK(b.geterror().find("bake: the offset map has 1 channel(s)") != std::string::npos);
}
