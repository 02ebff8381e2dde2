// SPDX-License-Identifier: Apache-2.0
// --normals: a height's own normals against the golden model, their
// boundary and their integer files.
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

TEST_CASE("normals: the device equals the golden model", "[check]")
{
    // Odd sizes, 1- and 2-texel lines: the edges and wraps of every case.
    // Each axis periodic or free.
    const auto boundary = [](bool periodic) { return periodic ? Boundary::Periodic : Boundary::Free; };
    for (auto [w, ht] : {std::pair{37, 23}, std::pair{1, 9}, std::pair{2, 5}, std::pair{64, 64}})
        for (auto [px, py] :
             {std::pair{true, true}, std::pair{false, false}, std::pair{true, false}, std::pair{false, true}})
            for (bool directx : {false, true}) {
                const std::vector<float> h =
                    test::random_field(std::size_t(w) * ht, unsigned(w * 7 + ht), -3.0f, 3.0f);
                NormalsOptions o;
                o.boundary = {boundary(px), boundary(py)};
                o.convention = directx ? NormalConvention::DirectX : NormalConvention::OpenGL;
                o.scale = 0.7f;
                OIIO::ImageBuf out = relief::normals(test::image(w, ht, 1, h), o);
                REQUIRE(out.initialized());
                REQUIRE(out.nchannels() == 3);
                const auto want = reference::height_normals(as_double(h), w, ht, px, py, 0.7, directx);
                INFO(w << "x" << ht << " periodic x " << px << ", y " << py << ", directx " << directx);
                CHECK(test::max_abs_diff(test::pixels(out), want) < 1e-5);
            }
}

TEST_CASE("normals: a tilted plane gives its own normal, one-sided at free edges", "[check]")
{
    // h = 0.5 x - 2 y: every difference, central or one-sided, is exact.
    const int w = 9, ht = 7;
    std::vector<float> h(w * ht);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x)
            h[y * w + x] = 0.5f * x - 2.0f * y;
    NormalsOptions o;
    o.boundary = Boundary::Free;
    const std::vector<float> n = test::pixels(relief::normals(test::image(w, ht, 1, h), o));
    const double len = std::sqrt(0.25 + 4.0 + 1.0);
    for (std::size_t t = 0; t < h.size(); ++t) {
        CHECK(n[3 * t] == Approx(-0.5 / len).margin(1e-6));
        CHECK(n[3 * t + 1] == Approx(-(2.0 / len)).margin(1e-6));  // OpenGL: G = -n_y, n_y = 2/len
        CHECK(n[3 * t + 2] == Approx(1.0 / len).margin(1e-6));
    }
}

TEST_CASE("normals: auto takes the boundary the height was integrated with, else each axis's seam test",
          "[check]")
{
    // A ramp jumps across the seam: the seam test alone says free.
    const int w = 16, ht = 16;
    std::vector<float> h(w * ht);
    for (int i = 0; i < w * ht; ++i)
        h[i] = float(i % w);
    OIIO::ImageBuf img = test::image(w, ht, 1, h);
    NormalsOptions free_o, periodic_o, auto_o;
    free_o.boundary = Boundary::Free;
    periodic_o.boundary = Boundary::Periodic;
    const auto f = test::pixels(relief::normals(img, free_o));
    const auto p = test::pixels(relief::normals(img, periodic_o));
    CHECK(test::max_abs_diff(test::pixels(relief::normals(img, auto_o)), f) == 0.0);
    img.specmod().attribute("relief:parameters", "method=poisson boundary=periodic highpass=0");
    CHECK(test::max_abs_diff(test::pixels(relief::normals(img, auto_o)), p) == 0.0);
    CHECK(test::max_abs_diff(f, p) > 0.1);

    // Without a record each axis takes its own seam test: a ramp along x
    // with a whole wave along y tiles along y only.
    for (int i = 0; i < w * ht; ++i)
        h[i] = float(i % w) + 3.0f * float(std::sin(2.0 * M_PI * (i / w) / ht));
    const OIIO::ImageBuf wave = test::image(w, ht, 1, h);
    NormalsOptions fp;
    fp.boundary = {Boundary::Free, Boundary::Periodic};
    const auto want = test::pixels(relief::normals(wave, fp));
    CHECK(test::max_abs_diff(test::pixels(relief::normals(wave, auto_o)), want) == 0.0);
    CHECK(test::max_abs_diff(test::pixels(relief::normals(wave, free_o)), want) > 0.01);
}

TEST_CASE("normals: auto on a height one texel wide or tall is free (a seam needs two texels)", "[check]")
{
    // Period 3 along the long axis: its seam alone would pass as periodic.
    for (const auto& [w, ht] : {std::pair<int, int>{12, 1}, {1, 12}}) {
        INFO(w << "x" << ht);
        std::vector<float> h(std::size_t(w) * ht);
        for (std::size_t i = 0; i < h.size(); ++i)
            h[i] = 0.25f * float(i % 3);
        const OIIO::ImageBuf img = test::image(w, ht, 1, h);
        NormalsOptions free_o, periodic_o, auto_o;
        free_o.boundary = Boundary::Free;
        periodic_o.boundary = Boundary::Periodic;
        const auto f = test::pixels(relief::normals(img, free_o));
        CHECK(test::max_abs_diff(test::pixels(relief::normals(img, auto_o)), f) == 0.0);
        CHECK(test::max_abs_diff(test::pixels(relief::normals(img, periodic_o)), f) > 0.01);
    }
}

TEST_CASE("normals: refuses NaN heights and directx/opengl only", "[check]")
{
    std::vector<float> h(16, 0.0f);
    h[5] = NAN;
    OIIO::ImageBuf out;
    CHECK_FALSE(relief::normals(out, test::image(4, 4, 1, h)));
    CHECK_THAT(geterror(), Catch::Contains("NaN or infinite value at texel (1, 1)"));
    NormalsOptions o;
    o.convention = NormalConvention::Auto;
    CHECK_FALSE(relief::normals(out, test::image(4, 4, 1, std::vector<float>(16, 0.0f)), o));
}

TEST_CASE("normals: the command line writes (v + 1)/2 in integer files and the decoded height round-trips",
          "[check][cli]")
{
    const fs::path d = test::scratch("check_normals_cli");
    const auto r = run_cli("'" + kNormalMap + "' --height:normal=opengl -o '" + (d / "h.exr").string() +
                           "' --normals:normal=directx -o '" + (d / "n.exr").string() + "' -d uint16 -o '" +
                           (d / "n.png").string() + "'");
    REQUIRE(r.rc == 0);
    const auto f = test::file_pixels(d / "n.exr"), u = test::file_pixels(d / "n.png");
    REQUIRE(f.size() == u.size());
    std::vector<float> decoded(u.size());
    for (std::size_t i = 0; i < u.size(); ++i)
        decoded[i] = 2.0f * u[i] - 1.0f;
    CHECK(test::max_abs_diff(f, decoded) < 2.0 / 65535.0);
    // The float file against the golden model of the height just written.
    const auto h = test::file_pixels(d / "h.exr");
    const auto want = reference::height_normals(as_double(h), 512, 512, true, 1.0, true);
    CHECK(test::max_abs_diff(f, want) < 1e-5);
}

TEST_CASE(
    "normals and levels read back from integer files are plain data: writing them again keeps the codes",
    "[check][io]")
{
    const fs::path d = test::scratch("check_reencode");
    const OIIO::ImageBuf h = test::image(16, 12, 1, test::waves(16, 12, 3.0, 2));
    for (const OIIO::ImageBuf& img :
         {relief::normals(h), relief::tessellation(h, TessellationOptions{4, 0.05f, 1.0f, {}})}) {
        INFO(img.spec().get_string_attribute("relief:method"));
        WriteOptions w;
        w.format = OIIO::TypeDesc::UINT8;
        REQUIRE(write_image(img, (d / "a.png").string(), w));
        OIIO::ImageBuf back;
        REQUIRE(read_image(back, (d / "a.png").string()));
        CHECK(back.spec().get_string_attribute("relief:method").empty());
        REQUIRE(write_image(back, (d / "b.png").string(), w));
        CHECK(test::file_pixels(d / "a.png") == test::file_pixels(d / "b.png"));
    }
}
