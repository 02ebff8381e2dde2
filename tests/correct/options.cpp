// SPDX-License-Identifier: Apache-2.0
// The correction's options reach the solver and the report is the solver's
// (bit for bit against the host call with the same parameters), scale=auto,
// boundary=auto, skip and max_iterations.
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

// A correction option's case: how the API's options and the host's
// parameters each say it, from scale 0.3, centre nodes, periodic.
struct CorrectCase {
    const char* name;
    std::function<void(CorrectOptions&)> api;
    std::function<void(host::CorrectParams&)> host;
};

// A choice the options and the host's parameters hold alike (the public
// enums of relief/correct_types.h), set to `value` on both.
template <class T>
CorrectCase choice_case(const char* name, T CorrectOptions::*api_field, T host::CorrectParams::*host_field,
                        T value)
{
    return {name, [api_field, value](CorrectOptions& o) { o.*api_field = value; },
            [host_field, value](host::CorrectParams& p) { p.*host_field = value; }};
}

// Corner nodes with `n` polish iterations.
CorrectCase corner_polish(const char* name, int n)
{
    return {name,
            [n](CorrectOptions& o) {
                o.nodes = CorrectNodes::Corner;
                o.polish = n;
            },
            [n](host::CorrectParams& p) {
                p.corner_nodes = true;
                p.polish = n;
            }};
}

// Each case's API result equals the host call with its parameters, bit for
// bit, and the report and the metadata say what the solver did; every case
// but the first ("base", which the last equals when it is "skip off")
// changes the offsets: no option is ignored unseen.
void check_correct_cases(const std::vector<float>& hts, const ImageBuf& height, int w, int h,
                         const std::vector<CorrectCase>& cases)
{
    std::vector<std::vector<float>> results;
    for (const CorrectCase& c : cases) {
        INFO(c.name);
        CorrectOptions o;
        o.scale = 0.3f;
        o.nodes = CorrectNodes::Center;
        o.boundary = CorrectBoundary::Periodic;
        c.api(o);
        host::CorrectParams p;
        p.scale = 0.3f;
        p.corner_nodes = false;
        p.periodic = true;
        c.host(p);
        const ApiCorrection got = api_correct(height, o);
        const HostCorrection want = host_correct(hts, w, h, p);
        CHECK(max_abs_diff(got.offsets, want.offsets) == 0.0);
        const CorrectReport& r = got.report;
        CHECK(r.skipped == want.report.skipped);
        CHECK(r.energy_before == want.report.energy_before);
        CHECK(r.energy_after == want.report.energy_after);
        CHECK(r.iterations == want.report.total_iterations());
        CHECK(r.polish.iterations == want.report.polish.iterations);
        CHECK(r.polish.energy_start == want.report.polish.energy_start);
        CHECK(r.polish.energy_end == want.report.polish.energy_end);
        CHECK(r.polish.flipped == want.report.polish.flipped);
        CHECK(r.polish.repairs == want.report.polish.repairs);
        REQUIRE(r.levels.size() == want.report.levels.size());
        for (std::size_t l = 0; l < r.levels.size(); ++l) {
            const host::CorrectLevel& hl = want.report.levels[l];
            CHECK(r.levels[l].iterations == hl.iterations);
            CHECK(r.levels[l].energy_start == hl.energy_start);
            CHECK(r.levels[l].energy_end == hl.energy_end);
            CHECK(r.levels[l].width == hl.width);
            CHECK(r.levels[l].height == hl.height);
            CHECK(r.levels[l].converged == hl.converged);
            CHECK(r.levels[l].tiles_run == Approx(double(hl.tile_phases_run) / double(hl.tile_phases)));
            CHECK(r.levels[l].start_factor == hl.start_factor);
            CHECK(r.levels[l].hat_sweeps == hl.hat_sweeps);
        }
        for (const auto& [got_s, want_s] : {std::pair{r.anisotropy_before, want.report.anisotropy_before},
                                            std::pair{r.anisotropy_after, want.report.anisotropy_after},
                                            std::pair{r.area_before, want.report.area_before},
                                            std::pair{r.area_after, want.report.area_after}}) {
            CHECK(got_s.mean == want_s.mean);
            CHECK(got_s.p95 == want_s.p95);
            CHECK(got_s.max == want_s.max);
        }
        CHECK(r.width == w);
        CHECK(r.height == h);
        const auto json = nlohmann::json::parse(r.to_json());
        CHECK(json["width"] == 40);
        CHECK(json["height"] == 36);
        CHECK(json["levels"].size() == r.levels.size());
        CHECK(json["polish"].value("iterations", -1) == r.polish.iterations);
        CHECK(json["polish"].value("energy_end", -1.0) == r.polish.energy_end);
        for (std::size_t l = 0; l < r.levels.size(); ++l) {
            CHECK(json["levels"][l].value("start_factor", -1.0) == r.levels[l].start_factor);
            CHECK(json["levels"][l].value("hat_sweeps", -1) == r.levels[l].hat_sweeps);
        }
        const auto word = [](bool periodic) { return std::string(periodic ? "periodic" : "fixed"); };
        CHECK(r.boundary == (p.periodic.x == p.periodic.y ? word(p.periodic.x)
                                                          : word(p.periodic.x) + "," + word(p.periodic.y)));
        CHECK(r.nodes == (p.corner_nodes ? "corner" : "center"));
        CHECK(r.scale == Approx(p.scale));
        CHECK(got.image.spec().get_string_attribute("relief:boundary") == r.boundary);
        CHECK(got.image.spec().get_string_attribute("relief:nodes") == r.nodes);
        CHECK(got.image.spec().get_float_attribute("relief:scale") == Approx(p.scale));
        CHECK(got.image.spec().get_string_attribute("relief:method") == "correct");
        const std::string par = got.image.spec().get_string_attribute("relief:parameters");
        CHECK(par.find("theta=" + test::format_number(p.theta)) != std::string::npos);
        CHECK(par.find(" threshold=" + test::format_number(p.threshold)) != std::string::npos);
        CHECK(par.find("nodes=" + r.nodes) != std::string::npos);
        CHECK(par.find("boundary=" + r.boundary) != std::string::npos);
        CHECK(par.find(std::string(" hats=") + (p.hats == host::CorrectParams::Hats::Off      ? "off"
                                                : p.hats == host::CorrectParams::Hats::Always ? "always"
                                                                                              : "auto")) !=
              std::string::npos);
        CHECK(par.find(std::string(" global=") + (p.global == host::CorrectParams::Global::Off ? "off"
                                                  : p.global == host::CorrectParams::Global::Always
                                                      ? "always"
                                                      : "auto")) != std::string::npos);
        CHECK(par.find(" polish=" + std::to_string(p.corner_nodes ? p.polish : 0)) != std::string::npos);
        CHECK(r.polish.iterations == (p.corner_nodes && !r.skipped ? p.polish : 0));
        CHECK(par.find(" levels=" + (p.levels ? std::to_string(p.levels) : std::string("auto"))) !=
              std::string::npos);
        CHECK(par.find(" iterations=" + (p.iterations ? std::to_string(p.iterations)
                                                      : std::string("auto"))) != std::string::npos);
        if (!r.skipped) {
            CHECK(r.energy_after < r.energy_before * 0.999);
            CHECK(r.anisotropy_after.mean < r.anisotropy_before.mean);
        }
        results.push_back(got.offsets);
    }
    if (std::string(cases.back().name) == "skip off")
        CHECK(results.back() == results.front());  // the same bits
    for (std::size_t a = 0; a + 1 < results.size(); ++a)
        for (std::size_t b = a + 1; b + (std::string(cases.back().name) == "skip off") < results.size();
             ++b) {
            // On this map auto takes a global step after every iteration, as
            // always does; the max_iterations test tells them apart.
            if (std::string(cases[a].name) == "base" && std::string(cases[b].name) == "global always")
                continue;
            INFO(cases[a].name << " vs " << cases[b].name);
            CHECK(max_abs_diff(results[a], results[b]) > 1e-7);
        }
}

// The height map the correction cases run on, with a fixation mask image
// (channel 0 = weights) and the tent's weights computed here from the
// documented formula max(0, 1 - |h - H0| / DH).
struct CorrectFixture {
    const int w = 40, h = 36;
    const std::vector<float> hts = waves(w, h, 1.0, 4);
    const ImageBuf height = test::image(w, h, 1, hts);
    std::vector<float> fix, tent;
    ImageBuf fix_image;
    CorrectFixture() : fix(std::size_t(w) * h), tent(fix.size())
    {
        std::vector<float> fix_px(3 * fix.size());
        for (std::size_t i = 0; i < fix.size(); ++i) {
            fix[i] = 2.0f + float(i % 7);
            fix_px[3 * i] = fix[i];
            fix_px[3 * i + 1] = 0.0f;
            fix_px[3 * i + 2] = 100.0f;
            tent[i] = std::max(0.0f, 1.0f - std::abs(hts[i] - 0.2f) / 0.5f);
        }
        fix_image = test::image(w, h, 3, fix_px);
    }
};

}  // namespace

TEST_CASE("options: every correction option reaches the solver, the report is the solver's",
          "[options][correct]")
{
    CorrectFixture f;
    const std::vector<float>& fix = f.fix;
    const std::vector<float>& tent = f.tent;
    const ImageBuf& fix_image = f.fix_image;
    const std::vector<CorrectCase> cases = {
        {"base", [](CorrectOptions&) {}, [](host::CorrectParams&) {}},
        {"corner nodes", [](CorrectOptions& o) { o.nodes = CorrectNodes::Corner; },
         [](host::CorrectParams& p) { p.corner_nodes = true; }},
        {"fixed boundary", [](CorrectOptions& o) { o.boundary = CorrectBoundary::Fixed; },
         [](host::CorrectParams& p) { p.periodic = false; }},
        {"corner nodes, fixed",
         [](CorrectOptions& o) {
             o.nodes = CorrectNodes::Corner;
             o.boundary = CorrectBoundary::Fixed;
         },
         [](host::CorrectParams& p) {
             p.corner_nodes = true;
             p.periodic = false;
         }},
        {"periodic,fixed",
         [](CorrectOptions& o) {
             o.boundary = {CorrectBoundary::Periodic, CorrectBoundary::Fixed};
         },
         [](host::CorrectParams& p) { p.periodic = host::Periodic(true, false); }},
        {"corner nodes, fixed,periodic",
         [](CorrectOptions& o) {
             o.nodes = CorrectNodes::Corner;
             o.boundary = {CorrectBoundary::Fixed, CorrectBoundary::Periodic};
         },
         [](host::CorrectParams& p) {
             p.corner_nodes = true;
             p.periodic = host::Periodic(false, true);
         }},
        corner_polish("corner nodes, polish 0", 0),
        corner_polish("corner nodes, polish 3", 3),
        {"scale 0.5", [](CorrectOptions& o) { o.scale = 0.5f; },
         [](host::CorrectParams& p) { p.scale = 0.5f; }},
        {"3 iterations", [](CorrectOptions& o) { o.iterations = 3; },
         [](host::CorrectParams& p) { p.iterations = 3; }},
        {"tolerance 1e-2", [](CorrectOptions& o) { o.tolerance = 1e-2f; },
         [](host::CorrectParams& p) { p.tolerance = 1e-2f; }},
        {"1 level", [](CorrectOptions& o) { o.levels = 1; }, [](host::CorrectParams& p) { p.levels = 1; }},
        {"threshold 3 (nothing to do)", [](CorrectOptions& o) { o.threshold = 3; },
         [](host::CorrectParams& p) { p.threshold = 3; }},
        {"fixation mask", [&](CorrectOptions& o) { o.fix_mask = &fix_image; },
         [&](host::CorrectParams& p) { p.fix_weights = fix.data(); }},
        {"fixation tent",
         [](CorrectOptions& o) {
             o.fix_height = 0.2f;
             o.fix_width = 0.5f;
         },
         [&](host::CorrectParams& p) { p.fix_weights = tent.data(); }},
        {"relax 1.2", [](CorrectOptions& o) { o.relax = 1.2f; },
         [](host::CorrectParams& p) { p.relax = 1.2f; }},
        choice_case("hats auto", &CorrectOptions::hats, &host::CorrectParams::hats, CorrectHats::Auto),
        choice_case("hats always", &CorrectOptions::hats, &host::CorrectParams::hats, CorrectHats::Always),
        choice_case("global off", &CorrectOptions::global, &host::CorrectParams::global, CorrectGlobal::Off),
        choice_case("global always", &CorrectOptions::global, &host::CorrectParams::global,
                    CorrectGlobal::Always),
        {"skip off", [](CorrectOptions& o) { o.skip_tiles = false; },
         [](host::CorrectParams& p) { p.skip_tiles = false; }},
    };
    check_correct_cases(f.hts, f.height, f.w, f.h, cases);
}

// Each of these builds correct.cl anew (CORRECT_ITHETA, CORRECT_SEARCH).
TEST_CASE("options: the correction's area exponent and line search reach the solver",
          "[options][correct][slow][kernel]")
{
    CorrectFixture f;
    const std::vector<CorrectCase> cases = {
        {"base", [](CorrectOptions&) {}, [](host::CorrectParams&) {}},
        {"theta 2", [](CorrectOptions& o) { o.theta = 2; }, [](host::CorrectParams& p) { p.theta = 2; }},
        {"theta 7.5", [](CorrectOptions& o) { o.theta = 7.5f; },
         [](host::CorrectParams& p) { p.theta = 7.5; }},
        choice_case("ternary search", &CorrectOptions::search, &host::CorrectParams::search,
                    CorrectSearch::Ternary),
        choice_case("golden search", &CorrectOptions::search, &host::CorrectParams::search,
                    CorrectSearch::Golden),
    };
    check_correct_cases(f.hts, f.height, f.w, f.h, cases);
}

TEST_CASE("options: relief's own heights imply scale 1/width, others need one", "[options][correct]")
{
    const int w = 32, h = 24;
    const auto hts = waves(w, h, 3.0, 2);
    ImageBuf own = test::image(w, h, 1, hts);
    own.specmod().attribute("relief:height_unit", "texel");
    CorrectOptions o;
    o.nodes = CorrectNodes::Center;
    o.boundary = CorrectBoundary::Periodic;
    const ApiCorrection got = api_correct(own, o);
    host::CorrectParams p;
    p.scale = 1.0 / w;
    p.corner_nodes = false;
    p.periodic = true;
    CHECK(max_abs_diff(got.offsets, host_correct(hts, w, h, p).offsets) == 0.0);
    CHECK(got.report.scale == Approx(1.0 / w));
    CHECK_FALSE(got.report.skipped);
    ImageBuf other = test::image(w, h, 1, hts);
    ImageBuf dst;
    CHECK_FALSE(relief::correct(dst, other, o));
    CHECK(relief::geterror().find("scale") != std::string::npos);
}

TEST_CASE("options: correction boundary=auto finds tiling maps and crops", "[options][correct][tiling]")
{
    const int w = 48, h = 40;
    const auto hts = waves(w, h, 1.0, 11);
    // The top-left 30 x 26 of a tiling field does not tile; its left 30
    // columns tile along y only (the top/bottom seam continuous).
    auto cut = [&](int cw, int ch) {
        std::vector<float> crop(std::size_t(cw) * ch);
        for (int y = 0; y < ch; ++y)
            for (int x = 0; x < cw; ++x)
                crop[std::size_t(y) * cw + x] = hts[std::size_t(y) * w + x];
        return crop;
    };
    const auto crop = cut(30, 26), strip = cut(30, h);
    using B = CorrectBoundaries;
    for (const auto& [px, iw, ih, want, word] :
         {std::tuple{&hts, w, h, B(CorrectBoundary::Periodic), "periodic"},
          std::tuple{&crop, 30, 26, B(CorrectBoundary::Fixed), "fixed"},
          std::tuple{&strip, 30, h, B(CorrectBoundary::Fixed, CorrectBoundary::Periodic),
                     "fixed,periodic"}}) {
        INFO(iw << "x" << ih << ": " << word);
        const ImageBuf img = test::image(iw, ih, 1, *px);
        CorrectOptions o;
        o.scale = 0.3f;
        o.nodes = CorrectNodes::Center;
        const ApiCorrection got = api_correct(img, o);
        CHECK(got.report.boundary == word);
        CHECK(got.said.find(std::string("boundary ") + word + " (") != std::string::npos);
        o.boundary = want;
        CHECK(max_abs_diff(api_correct(img, o).offsets, got.offsets) == 0.0);
    }
}

TEST_CASE("options: correction skip=on skips still tiles, skip=off runs them all", "[options][correct]")
{
    // A bump in a flat sea, one level: far tiles have nothing to do.
    const int w = 96, h = 80;
    std::vector<float> hts(std::size_t(w) * h, 0.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double r2 = ((x - 20.0) * (x - 20.0) + (y - 18.0) * (y - 18.0)) / 25.0;
            hts[std::size_t(y) * w + x] = r2 < 9 ? float(std::exp(-r2)) : 0.0f;
        }
    const ImageBuf height = test::image(w, h, 1, hts);
    CorrectOptions o;
    o.scale = 0.15f;
    o.nodes = CorrectNodes::Center;
    o.boundary = CorrectBoundary::Periodic;
    o.levels = 1;
    o.global = CorrectGlobal::Off;  // global steps wake every tile
    const ApiCorrection on = api_correct(height, o);
    o.skip_tiles = false;
    const ApiCorrection off = api_correct(height, o);
    CHECK(max_abs_diff(on.offsets, off.offsets) == 0.0);
    CHECK(on.report.levels.back().tiles_run < 1.0);  // measured 0.984
    CHECK(off.report.levels.back().tiles_run == 1.0);
}

TEST_CASE("options: max_iterations stops a level that has not converged, and says so", "[options][correct]")
{
    const int w = 40, h = 36;
    const auto hts = waves(w, h, 1.0, 4);
    CorrectOptions o;
    o.scale = 0.3f;
    o.nodes = CorrectNodes::Center;
    o.boundary = CorrectBoundary::Periodic;
    o.levels = 1;
    o.max_iterations = 4;
    // A global step counts as the half iteration it costs: three
    // iterations, and steps after the first two (the third would pass the
    // limit).
    const ApiCorrection got = api_correct(test::image(w, h, 1, hts), o);
    REQUIRE(got.report.levels.size() == 1);
    CHECK(got.report.levels[0].iterations == 3);
    CHECK(got.report.levels[0].global_steps == 2);
    CHECK_FALSE(got.report.levels[0].converged);
    CHECK(got.said.find("stopped at 4 iterations (each global step counted as the iterations it costs)") !=
          std::string::npos);
    host::CorrectParams p;
    p.scale = 0.3f;
    p.corner_nodes = false;
    p.levels = 1;
    p.max_iterations = 4;
    CHECK(max_abs_diff(got.offsets, host_correct(hts, w, h, p).offsets) == 0.0);
    // global=always steps whatever the limit leaves.
    o.global = CorrectGlobal::Always;
    const ApiCorrection always = api_correct(test::image(w, h, 1, hts), o);
    CHECK(always.report.levels[0].iterations == 3);
    CHECK(always.report.levels[0].global_steps == 3);
    o.global = CorrectGlobal::Off;
    o.max_iterations = 2;
    const ApiCorrection plain = api_correct(test::image(w, h, 1, hts), o);
    CHECK(plain.report.levels[0].iterations == 2);
    CHECK(plain.said.find("stopped at 2 iterations before") != std::string::npos);
    // A level that swept says that its sweeps counted towards the limit.
    const int n = 128;
    o.scale = 1.0f;
    o.max_iterations = 60;
    o.tolerance = 1e-9f;
    o.hats = CorrectHats::Auto;
    o.global = CorrectGlobal::Off;
    const ApiCorrection swept = api_correct(test::image(n, n, 1, waves(n, n, 1.0, 23)), o);
    REQUIRE(swept.report.levels.size() == 1);
    CHECK(swept.report.levels[0].hat_sweeps > 0);
    CHECK(swept.said.find("stopped at 60 iterations (each hat sweep counted as the iterations it costs)") !=
          std::string::npos);
    CHECK(got.said.find("hat sweep") == std::string::npos);
    CHECK(swept.said.find("global step") == std::string::npos);
}
