// SPDX-License-Identifier: Apache-2.0
// The round trip: a height's normals against the input's, in --report.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <tiny_gltf.h>

#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <random>

#include "check/check_stage.h"
#include "device/compute_context.h"
#include "reference/check_reference.h"
#include "reference/ddm_reference.h"
#include "relief/check.h"
#include "relief/errors.h"
#include "relief/height.h"
#include "relief/imageio.h"
#include "relief/mesh.h"
#include "relief/preview.h"
#include "relief/relief_c.h"
#include "relief/slopes.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/run_cli.h"
#include "check/check_test.h"

using namespace relief;
using namespace relief::test::checks;

TEST_CASE("round trip: HeightReport equals the golden model under the boundary the height used", "[check]")
{
    // A small tiling map: its border texels (a quarter of them) tell
    // wrapped differences from one-sided ones.
    const int w = 24, ht = 20;
    NormalsOptions no;
    no.boundary = Boundary::Periodic;
    const OIIO::ImageBuf normals = relief::normals(test::image(w, ht, 1, test::waves(w, ht, 3.0, 9)), no);
    SlopeOptions so;
    so.normals.convention = NormalConvention::OpenGL;
    const auto g = as_double(test::pixels(relief::slopes(normals, so)));
    const auto boundary = [](bool periodic) { return periodic ? Boundary::Periodic : Boundary::Free; };
    const auto word = [](bool periodic) { return std::string(periodic ? "periodic" : "free"); };
    for (auto [px, py] :
         {std::pair{true, true}, std::pair{false, false}, std::pair{true, false}, std::pair{false, true}}) {
        HeightOptions o;
        o.normals.convention = NormalConvention::OpenGL;
        o.boundary = {boundary(px), boundary(py)};
        HeightReport r;
        o.report = &r;
        const auto h = as_double(test::pixels(relief::height(normals, o)));
        const auto want = reference::round_trip(g, h, w, ht, px, py);
        // (each axis's differences count: the other boundary along either)
        const auto other = reference::round_trip(g, h, w, ht, px == py ? !px : py, px == py ? !py : px);
        INFO("periodic x " << px << ", y " << py);
        CHECK(r.boundary == (px == py ? word(px) : word(px) + "," + word(py)));
        CHECK(r.angular_error_mean == Approx(want.mean).epsilon(1e-4).margin(1e-6));
        CHECK(r.angular_error_p95 == Approx(want.p95).epsilon(1e-4).margin(1e-6));
        CHECK(r.angular_error_max == Approx(want.max).epsilon(1e-4).margin(1e-6));
        CHECK(r.residual_share == Approx(want.residual_share).epsilon(1e-4).margin(1e-9));
        CHECK(std::abs(other.mean - want.mean) > 1e-3 * want.mean + 1e-3);
    }
}

TEST_CASE("round trip: --report's height object matches an independent computation", "[check][cli]")
{
    const fs::path d = test::scratch("check_round_trip");
    // The golden DDM of the input (8-bit OpenGL/DirectX codes, the default 85 degree clamp).
    const std::vector<float> codes = test::file_pixels(kNormalMap);
    for (const char* method : {"poisson:boundary=free", "rays:radius=16:boundary=periodic"}) {
        const bool periodic = std::string(method).find("periodic") != std::string::npos;
        const auto r = run_cli("'" + kNormalMap + "' --height:normal=directx:method=" + method + " -o '" +
                               (d / "h.exr").string() + "' --report '" + (d / "r.json").string() + "' -v");
        INFO(method << ": " << r.err);
        REQUIRE(r.rc == 0);
        const std::string json = test::slurp(d / "r.json");
        REQUIRE(json.find("\"height\": {") != std::string::npos);
        CHECK(json.find("\"correct\"") == std::string::npos);
        CHECK(json.find(std::string("\"method\": \"") + (periodic ? "rays" : "poisson") + "\"") !=
              std::string::npos);
        CHECK(json.find("\"normal_convention\": \"directx\"") != std::string::npos);
        CHECK(json.find(std::string("\"boundary\": \"") + (periodic ? "periodic" : "free") + "\"") !=
              std::string::npos);
        const auto h = test::file_pixels(d / "h.exr");
        const auto g = reference::ddm(codes, 3, 2.0, -1.0, +1.0, 85.0, 1.001 / 255.0).slopes;
        const auto want = reference::round_trip(g, as_double(h), 512, 512, periodic);
        CHECK(json_number(json, "mean") == Approx(want.mean).epsilon(1e-3));
        CHECK(json_number(json, "p95") == Approx(want.p95).epsilon(1e-3));
        CHECK(json_number(json, "max") == Approx(want.max).epsilon(1e-3));
        CHECK(json_number(json, "residual_share") == Approx(want.residual_share).epsilon(1e-3));
        CHECK(want.mean > 0.05);
        // -v prints the same.
        CHECK(r.err.find("round trip: angular error mean") != std::string::npos);
    }
}

TEST_CASE("round trip: --report holds height and correct, written only when the job ends", "[check][cli]")
{
    const fs::path d = test::scratch("check_report_both");
    auto r =
        run_cli("'" + kNormalMap + "' --dup --height -o '" + (d / "h.exr").string() +
                "' --correct --report '" + (d / "r.json").string() + "' -o '" + (d / "o.exr").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    const std::string json = test::slurp(d / "r.json");
    const std::size_t hgt = json.find("\"height\": {"), cor = json.find("\"correct\": {");
    REQUIRE(hgt != std::string::npos);
    REQUIRE(cor != std::string::npos);
    CHECK(hgt < cor);
    CHECK(json_number(json, "energy_after", cor) < json_number(json, "energy_before", cor));
    CHECK(std::isnan(json_number(json, "energy_after", 0)) == false);
    CHECK(json_number(json, "mean", hgt) > 0.0);
    // A job that fails after its --height (a fixation mask of the wrong
    // size) leaves no report.
    fs::remove(d / "r.json");
    REQUIRE(write_image(test::image(4, 4, 1, std::vector<float>(16, 1.0f)), (d / "fix.exr").string()));
    r = run_cli("'" + kNormalMap + "' --height --report '" + (d / "r.json").string() + "' -o '" +
                (d / "h2.exr").string() + "' --correct:fix=" + (d / "fix.exr").string() + " -o '" +
                (d / "o2.exr").string() + "'");
    CHECK(r.rc == 1);
    CHECK_FALSE(fs::exists(d / "r.json"));
}
