// SPDX-License-Identifier: Apache-2.0
// boundary=auto for heights on synthetic tiling and non-tiling maps, per axis.
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

TEST_CASE("options: boundary=auto integrates a tiling map periodically, a crop freely, a strip per axis",
          "[options][tiling][slow]")
{
    // A tiling field, and the top-left 60 x 50 of a larger tiling field (its
    // wrap seams join unrelated texels).
    const int big_w = 96, big_h = 80, w = 60, h = 50;
    const auto tiling = tiling_slopes(big_w, big_h, 7);
    const std::vector<double> crop = top_left(tiling, big_w, w, h);
    // And the left 60 columns at full height: only one seam joins unrelated texels.
    const std::vector<double> strip = top_left(tiling, big_w, w, big_h);
    const ImageBuf tile = test::normal_image(tiling, big_w, big_h, test::Green::OpenGL, TypeDesc::FLOAT);
    const ImageBuf part = test::normal_image(crop, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    const ImageBuf column = test::normal_image(strip, w, big_h, test::Green::OpenGL, TypeDesc::FLOAT);
    for (bool ray_method : {false, true}) {
        INFO((ray_method ? "rays" : "poisson"));
        HeightOptions o;
        if (ray_method) {
            o.method = HeightMethod::Rays;
            o.rays = 8;
            o.radius = 10;
        }
        // Each axis on its own: the strip integrates free along x, periodic
        // along y; rays take one boundary, clip unless both axes tile.
        const Boundaries periodic{Boundary::Periodic, Boundary::Periodic},
            free{Boundary::Free, Boundary::Free};
        const Boundaries strip_b = ray_method ? free : Boundaries{Boundary::Free, Boundary::Periodic};
        for (const auto& [img, chosen_b] :
             {std::pair{&tile, periodic}, std::pair{&part, free}, std::pair{&column, strip_b}}) {
            const bool tiles = chosen_b.x == Boundary::Periodic && chosen_b.y == Boundary::Periodic;
            std::string said;
            const auto got = api_height(*img, o, &said);
            HeightOptions explicit_b = o;
            explicit_b.boundary = chosen_b;
            const auto want = api_height(*img, explicit_b);
            INFO(said);
            CHECK(max_abs_diff(got, want) == 0.0);
            const auto word = [&](Boundary b) {
                return b == Boundary::Periodic ? "periodic" : (ray_method ? "clip" : "free");
            };
            const std::string chosen = chosen_b.x == chosen_b.y
                                           ? std::string(word(chosen_b.x))
                                           : std::string(word(chosen_b.x)) + "," + word(chosen_b.y);
            CHECK(said.find("boundary: " + chosen + " (") != std::string::npos);
            // relief:parameters records what was chosen, not "auto".
            HeightOptions again = o;
            again.normals.convention = NormalConvention::OpenGL;
            const std::string par =
                relief::height(*img, again).spec().get_string_attribute("relief:parameters");
            if (ray_method)
                CHECK(par ==
                      "method=rays impl=fast rays=8 radius=10 phase=0.5 directions=rational boundary=" +
                          chosen);
            else
                CHECK(par == "method=poisson boundary=" + chosen + " highpass=0");
            HeightOptions other = o;
            other.boundary = tiles ? Boundary::Free : Boundary::Periodic;
            CHECK(max_abs_diff(api_height(*img, other), got) > 1e-3);
        }
    }
}

TEST_CASE("options: a boundary per axis is kept, an axis left to auto takes its own verdict (both on auto "
          "too), the checks follow the height's",
          "[options][tiling]")
{
    // The left 64 columns of a tiling field at full height: it tiles along
    // y, and its x seam joins unrelated texels. (64 x 48: a size other fast
    // tests plan FFTs for.)
    const int big_w = 96, h = 48, w = 64;
    const auto tiling = tiling_slopes(big_w, h, 7);
    const std::vector<double> strip = top_left(tiling, big_w, w, h);
    const ImageBuf column = test::normal_image(strip, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    const Boundaries fp{Boundary::Free, Boundary::Periodic};
    HeightOptions o;
    o.boundary = fp;
    HeightReport report;
    o.report = &report;
    const auto want = api_height(column, o);
    CHECK(report.boundary == "free,periodic");
    for (Boundaries half :
         {Boundaries{Boundary::Auto, Boundary::Periodic}, Boundaries{Boundary::Free, Boundary::Auto},
          Boundaries{Boundary::Auto, Boundary::Auto}}) {
        HeightOptions a;
        a.boundary = half;
        std::string said;
        CHECK(max_abs_diff(api_height(column, a, &said), want) == 0.0);
        INFO(said);
        CHECK(said.find("boundary: free,periodic (") != std::string::npos);
    }
    for (Boundary both : {Boundary::Free, Boundary::Periodic}) {
        HeightOptions other;
        other.boundary = both;
        CHECK(max_abs_diff(api_height(column, other), want) > 1e-3);
    }
    o.report = nullptr;
    o.normals.convention = NormalConvention::OpenGL;
    const ImageBuf height = relief::height(column, o);
    REQUIRE_FALSE(height.has_error());
    CHECK(height.spec().get_string_attribute("relief:parameters") ==
          "method=poisson boundary=free,periodic highpass=0");

    // --normals on auto reads the height's boundary per axis.
    const auto normals_of = [&](Boundaries b, std::string* said = nullptr) {
        NormalsOptions n;
        n.boundary = b;
        if (said)
            n.exec.on_message = [said](Severity, const std::string& m) { *said += m + "\n"; };
        const ImageBuf out = relief::normals(height, n);
        REQUIRE_FALSE(out.has_error());
        return pixels(out);
    };
    std::string said;
    const auto followed = normals_of(Boundary::Auto, &said);
    CHECK(said.find(
              "normals: boundary free,periodic (the height was integrated with boundary=free,periodic)") !=
          std::string::npos);
    CHECK(followed == normals_of(fp));
    CHECK(followed == normals_of({Boundary::Auto, Boundary::Periodic}));
    CHECK(max_abs_diff(followed, normals_of(Boundary::Free)) > 1e-3);
    CHECK(max_abs_diff(followed, normals_of(Boundary::Periodic)) > 1e-3);
}

TEST_CASE("options: boundary=auto integrates a map whose wrap seam was painted over periodically",
          "[options][tiling][slow]")
{
    // Rough slopes on a smooth periodic surface, the first and last column
    // replaced by noise: the slope test fails the x seam, the block
    // heights still see the surface meet itself (0ad_desert_cliff's case).
    const int w = 384, h = 320;
    const test::PeriodicField f{w, h, {{3, 1, 40.0, 0.2}, {5, -4, 10.0, 1.0}, {11, 7, 3.0, 2.5}}};
    std::vector<double> g = test::plus_noise(f.slopes(), 1.5, 7);
    std::mt19937 rng(9);
    std::normal_distribution<double> noise(0.0, test::rms(g));
    for (int y = 0; y < h; ++y)
        for (int x : {0, w - 1})
            for (int c = 0; c < 2; ++c)
                g[2 * (std::size_t(y) * w + x) + c] = noise(rng);
    const ImageBuf img = test::normal_image(g, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    std::string said;
    const auto got = api_height(img, HeightOptions{}, &said);
    INFO(said);
    CHECK(said.find("boundary: periodic (x: ") != std::string::npos);
    CHECK(said.find("(fail), block heights step") != std::string::npos);
    HeightOptions periodic;
    periodic.boundary = Boundary::Periodic;
    CHECK(max_abs_diff(api_height(img, periodic), got) == 0.0);
}
