// SPDX-License-Identifier: Apache-2.0
// --preview: the sheet's layout, its lighting and its refusals.
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

namespace {

// The mean of channel c over panel (col, row) of a preview sheet whose
// panels are pw x ph (the layout of plugin/src/operations/preview.cpp).
double panel_mean(const OIIO::ImageBuf& sheet, int col, int row, int pw, int ph, int c, int inset = 4)
{
    const int x0 = 16 + col * (pw + 16), y0 = 16 + row * (34 + ph + 52 + 16) + 34;
    double sum = 0.0;
    int n = 0;
    for (int y = y0 + inset; y < y0 + ph - inset; ++y)
        for (int x = x0 + inset; x < x0 + pw - inset; ++x) {
            float v[3];
            sheet.getpixel(x, y, v);
            sum += v[c];
            ++n;
        }
    return sum / n;
}

}  // namespace

TEST_CASE("preview: spherical-harmonic irradiance of analytic environments", "[check][preview]")
{
    // A uniform environment of radiance 1 gives every normal pi.
    OIIO::ImageBuf uniform(OIIO::ImageSpec(64, 32, 3, OIIO::TypeDesc::FLOAT));
    const float one[3] = {1.0f, 1.0f, 1.0f};
    OIIO::ImageBufAlgo::fill(uniform, one);
    const SphericalHarmonics u = environment_harmonics(uniform);
    for (const auto& n : {std::array<float, 3>{0, 0, 1}, std::array<float, 3>{1, 0, 0},
                          std::array<float, 3>{0, -0.6f, 0.8f}}) {
        float e[3];
        irradiance(u, n.data(), e);
        CHECK(e[0] == Approx(M_PI).epsilon(0.01));
    }
    // The upper hemisphere alone (rows above the horizon): an upward normal
    // receives pi, a horizontal one pi/2; a downward one about 0 (order-2
    // harmonics ring slightly).
    OIIO::ImageBuf sky(OIIO::ImageSpec(64, 32, 3, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(sky, one, OIIO::ROI(0, 64, 0, 16));
    const SphericalHarmonics hs = environment_harmonics(sky);
    const float up[3] = {0, 0, 1}, side[3] = {0, 1, 0}, down[3] = {0, 0, -1};
    float e_up[3], e_side[3], e_down[3];
    irradiance(hs, up, e_up);
    irradiance(hs, side, e_side);
    irradiance(hs, down, e_down);
    CHECK(e_up[1] == Approx(M_PI).epsilon(0.05));
    CHECK(e_side[1] == Approx(M_PI / 2).epsilon(0.02));
    CHECK(std::abs(e_down[1]) < 0.1 * M_PI);
    for (const float sign : {1.0f, -1.0f}) {  // along x as along y: the sky has no side
        const float along_x[3] = {sign, 0, 0};
        float e_x[3];
        irradiance(hs, along_x, e_x);
        CHECK(e_x[1] == Approx(M_PI / 2).epsilon(0.02));
    }
    // Light from the image's right (azimuth 0) lights normals tilted to +x.
    OIIO::ImageBuf right(OIIO::ImageSpec(64, 32, 3, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(right, one, OIIO::ROI(0, 8, 8, 16));  // around azimuth 0, above the horizon
    const SphericalHarmonics r = environment_harmonics(right);
    const float px[3] = {0.7f, 0, 0.71f}, nx[3] = {-0.7f, 0, 0.71f}, py[3] = {0, -0.7f, 0.71f};
    float a[3], b[3], c[3];
    irradiance(r, px, a);
    irradiance(r, nx, b);
    irradiance(r, py, c);
    CHECK(a[0] > 2 * b[0]);
    CHECK(c[0] > b[0]);  // azimuth 0..45 leans toward the top (-y) of the image
}

TEST_CASE("preview: the documented command writes an 8-bit sheet at least 1024 wide", "[check][preview][cli]")
{
    const fs::path d = test::scratch("check_preview");
    const auto r =
        run_cli("'" + kNormalMap + "' --dup --height -o '" + (d / "h.exr").string() + "' --report '" +
                (d / "r.json").string() + "' --preview -o '" + (d / "sheet.png").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    auto in = OIIO::ImageInput::open((d / "sheet.png").string());
    REQUIRE(in);
    CHECK(in->spec().width >= 1024);
    CHECK(in->spec().nchannels == 3);
    CHECK(in->spec().format == OIIO::TypeDesc::UINT8);
    CHECK(fs::exists(d / "r.json"));
}

TEST_CASE("preview: any size lays out, from 1x1 to 65536x1, in the CLI, a batch and the C ABI",
          "[check][preview][cli][errors][stress][sizes]")
{
    // Panels under about 60 texels tall aborted in OIIO's render_text (the
    // statistics ran off the sheet's bottom), taking a batch's later jobs
    // and a C host with them.
    const fs::path d = test::scratch("check_preview_sizes");
    struct Size {
        int w, h;
    };
    const std::vector<Size> sizes = {{1, 1},      {6, 1},     {100, 16}, {1000, 50},
                                     {4096, 128}, {65536, 1}, {1, 4096}};
    std::ofstream manifest(d / "jobs.txt");
    std::vector<std::vector<float>> maps;
    for (const Size& z : sizes) {
        // Gentle bumps: unit normals of h = 0.3 sin(x / 3) cos(y / 5).
        std::vector<float> n(std::size_t(z.w) * z.h * 3);
        for (int y = 0; y < z.h; ++y)
            for (int x = 0; x < z.w; ++x) {
                const float gx = 0.1f * std::cos(x / 3.0f) * std::cos(y / 5.0f),
                            gy = -0.06f * std::sin(x / 3.0f) * std::sin(y / 5.0f);
                const float inv = 1.0f / std::sqrt(1.0f + gx * gx + gy * gy);
                float* p = &n[3 * (std::size_t(y) * z.w + x)];
                p[0] = -gx * inv;
                p[1] = -gy * inv;
                p[2] = inv;
            }
        maps.push_back(n);
        const std::string name = "n" + std::to_string(z.w) + "x" + std::to_string(z.h);
        REQUIRE(write_image(test::image(z.w, z.h, 3, n), (d / (name + ".exr")).string()));
        manifest << name << ".exr --dup --height --preview -o " << name << ".sheet.png\n";
    }
    manifest.close();
    // One command line each.
    for (const Size& z : sizes) {
        const std::string name = "n" + std::to_string(z.w) + "x" + std::to_string(z.h);
        INFO(name);
        const auto r = run_cli("-v " + name + ".exr --dup --height --preview -o " + name + ".cli.png",
                               "cd '" + d.string() + "' &&");
        INFO(r.err);
        CHECK(r.rc == 0);
        auto in = OIIO::ImageInput::open((d / (name + ".cli.png")).string());
        REQUIRE(in);
        CHECK(in->spec().width >= 3 * 344);
        CHECK(in->spec().height >= 2 * 100);
    }
    // A batch: every job ends, none takes the others with it.
    const auto r = run_cli("--batch jobs.txt", "cd '" + d.string() + "' &&");
    INFO(r.err);
    CHECK(r.rc == 0);
    CHECK(r.err.find(std::to_string(sizes.size()) + " ok, 0 skipped, 0 failed") != std::string::npos);
    // The C ABI: the host survives and gets a sheet.
    for (std::size_t i = 0; i < sizes.size(); ++i) {
        const Size z = sizes[i];
        INFO(z.w << "x" << z.h);
        relief_image normals = {z.w, z.h, 3, RELIEF_FLOAT, maps[i].data(), nullptr}, h{}, sheet{};
        REQUIRE(relief_run("height", "", &normals, 1, &h) == RELIEF_OK);
        const relief_image both[2] = {normals, h};
        CHECK(relief_run("preview", "", both, 2, &sheet) == RELIEF_OK);
        CHECK(sheet.width >= 3 * 344);
        relief_image_free(&h);
        relief_image_free(&sheet);
    }
}

TEST_CASE("preview: a height's own normals light as the height does, and the light comes from where it says",
          "[check][preview]")
{
    // A ramp rising to the right (free edges): its normals lean to -x.
    const int w = 64, ht = 48;
    std::vector<float> h(w * ht);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x)
            h[y * w + x] = 0.6f * x + 2.0f * std::sin(0.3 * y);
    OIIO::ImageBuf height = test::image(w, ht, 1, h);
    NormalsOptions no;
    no.boundary = Boundary::Free;
    const OIIO::ImageBuf normals = relief::normals(height, no);  // OpenGL, float
    PreviewOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    o.boundary = Boundary::Free;
    o.azimuth = 180.0f;  // from the left: the slope faces it
    OIIO::ImageBuf from_left = relief::preview(normals, height, o);
    REQUIRE_FALSE(from_left.has_error());
    // 64 texels are shown 344 wide (nearest texels).
    const int pw = 344, ph = int(std::lround(48 * 344.0 / 64));
    CHECK(from_left.spec().width == 3 * pw + 4 * 16);
    for (int c = 0; c < 3; ++c)
        CHECK(std::abs(panel_mean(from_left, 0, 0, pw, ph, c) - panel_mean(from_left, 1, 0, pw, ph, c)) <
              2.0 / 255);
    o.azimuth = 0.0f;
    OIIO::ImageBuf from_right = relief::preview(normals, height, o);
    // The same ramp turned to rise down the image faces a light from the
    // top of the image (azimuth 90).
    std::vector<float> hy(w * ht);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x)
            hy[y * w + x] = 0.6f * y + 2.0f * std::sin(0.3 * x);
    const OIIO::ImageBuf height_y = test::image(w, ht, 1, hy);
    const OIIO::ImageBuf normals_y = relief::normals(height_y, no);
    o.azimuth = 90.0f;
    const double from_top = panel_mean(relief::preview(normals_y, height_y, o), 1, 0, pw, ph, 1);
    o.azimuth = 270.0f;
    const double from_bottom = panel_mean(relief::preview(normals_y, height_y, o), 1, 0, pw, ph, 1);
    CHECK(from_top > from_bottom + 0.1);
    // A red environment lights the panels red; the sky, blue.
    const fs::path d = test::scratch("check_preview_env");
    OIIO::ImageBuf red(OIIO::ImageSpec(32, 16, 3, OIIO::TypeDesc::FLOAT));
    const float r[3] = {1.0f, 0.05f, 0.05f};
    OIIO::ImageBufAlgo::fill(red, r);
    REQUIRE(write_image(red, (d / "red.exr").string()));
    o.azimuth = 0.0f;
    o.elevation = 5.0f;  // a grazing key light leaves the colour to the environment
    const OIIO::ImageBuf lit_sky = relief::preview(normals, height, o);
    CHECK(panel_mean(lit_sky, 0, 0, pw, ph, 2) > panel_mean(lit_sky, 0, 0, pw, ph, 0) + 0.05);
    o.env = (d / "red.exr").string();
    const OIIO::ImageBuf lit_red = relief::preview(normals, height, o);
    CHECK(panel_mean(lit_red, 0, 0, pw, ph, 0) > panel_mean(lit_red, 0, 0, pw, ph, 2) + 0.2);
    CHECK(panel_mean(from_left, 1, 0, pw, ph, 1) > panel_mean(from_right, 1, 0, pw, ph, 1) + 0.1);
    // Emboss: the ramp rises toward a light on the right: brighter than mid-grey.
    CHECK(panel_mean(from_right, 2, 0, pw, ph, 0) > 0.6);
    CHECK(panel_mean(from_left, 2, 0, pw, ph, 0) < 0.4);
}

TEST_CASE("preview: the emboss panel is the height one texel toward the light less the height, along x and y",
          "[check][preview]")
{
    // Planes: the height one texel toward the light (bilinear between
    // texels, exact on a plane) less the height is the same everywhere but
    // at the clamped edges, under 1% of the texels here, so the panel is
    // black where it is lower, white where it is higher.
    const int w = 256, ht = 192;
    const int pw = 344, ph = int(std::lround(192 * 344.0 / 256));
    NormalsOptions no;
    no.boundary = Boundary::Free;
    PreviewOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    o.boundary = Boundary::Free;
    const auto emboss = [&](double ax, double ay, float azimuth) {
        std::vector<float> h(w * ht);
        for (int y = 0; y < ht; ++y)
            for (int x = 0; x < w; ++x)
                h[y * w + x] = float(ax * x + ay * y);
        const OIIO::ImageBuf height = test::image(w, ht, 1, h);
        o.azimuth = azimuth;
        const OIIO::ImageBuf sheet = relief::preview(relief::normals(height, no), height, o);
        REQUIRE_FALSE(sheet.has_error());
        return panel_mean(sheet, 2, 0, pw, ph, 0, 12);
    };
    // Rising down the image: the light from the top (azimuth 90) finds the
    // texel above lower, from the bottom higher.
    CHECK(emboss(0.0, 0.6, 90.0f) < 0.05);
    CHECK(emboss(0.0, 0.6, 270.0f) > 0.95);
    // Azimuth 45 looks 0.71 texels right and 0.71 up (between texels):
    // 0.3 x 0.71 higher and 0.6 x 0.71 lower; 315 looks right and down.
    CHECK(emboss(0.3, 0.6, 45.0f) < 0.05);
    CHECK(emboss(0.3, 0.6, 315.0f) > 0.95);
    CHECK(emboss(0.6, 0.3, 45.0f) > 0.95);
    CHECK(emboss(0.6, 0.3, 135.0f) < 0.05);
}

TEST_CASE("preview: the procedural sky lights an upward surface pale blue, every channel lit",
          "[check][preview]")
{
    // A flat map with the key light at the horizon: panel a is the sky's
    // diffuse light alone (zenith blue, a pale horizon, a brown ground).
    const int w = 400, h = 200;
    std::vector<float> up(std::size_t(w) * h * 3, 0.0f);
    for (std::size_t i = 2; i < up.size(); i += 3)
        up[i] = 1.0f;
    PreviewOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    o.elevation = 0.001f;
    const OIIO::ImageBuf sheet = relief::preview(
        test::image(w, h, 3, up), test::image(w, h, 1, std::vector<float>(std::size_t(w) * h, 0.0f)), o);
    REQUIRE_FALSE(sheet.has_error());
    const int W = sheet.spec().width;
    const std::vector<float> px = test::pixels(sheet);
    const int x = (W - 3 * w) / 4 + w / 2;  // the middle of panel a's column
    const auto at = [&](int y) { return &px[3 * (std::size_t(y) * W + x)]; };
    // Down to the first panel: 20 rows of one colour other than the
    // background's (a caption's letters are not that tall).
    const auto same = [&](int a, int b) { return std::equal(at(a), at(a) + 3, at(b)); };
    const auto panel_at = [&](int y) {
        for (int k = 0; k < 20; ++k)
            if (same(y + k, 0) || !same(y + k, y))
                return false;
        return true;
    };
    int y = 0;
    while (y + 20 < sheet.spec().height && !panel_at(y))
        ++y;
    REQUIRE(y + 20 < sheet.spec().height);
    const float* c = at(y + 10);
    INFO("sky light " << c[0] << ", " << c[1] << ", " << c[2]);
    CHECK(c[2] > c[0]);         // blue
    CHECK(c[0] > 0.5f * c[2]);  // pale: red well present
    CHECK(c[1] > c[0]);
}

TEST_CASE("preview: each panel is the map's size at the sheet's scale, in its own cell", "[check][preview]")
{
    // A flat map makes every panel one colour, so each can be found and
    // measured: pw x ph, the same size in every cell, cells in a grid with
    // equal margins, each panel's edges against the background. The panel
    // size follows the rule of the sheet: the map's own resolution, scaled
    // into 344..1024 texels wide (and at most 2048 tall when enlarged).
    struct Case {
        int w, h, pw, ph;
    } cases[] = {{400, 200, 400, 200}, {2048, 1024, 1024, 512}, {100, 300, 344, 1032}, {20, 1000, 41, 2048}};
    // The first case's panels are not resized; the others' are: each keeps
    // its colour.
    std::array<std::array<float, 3>, 5> unscaled{};
    for (const Case& c : cases) {
        INFO(c.w << "x" << c.h);
        std::vector<float> up(std::size_t(c.w) * c.h * 3, 0.0f);
        for (std::size_t i = 2; i < up.size(); i += 3)
            up[i] = 1.0f;
        const OIIO::ImageBuf normals = test::image(c.w, c.h, 3, up);
        const OIIO::ImageBuf flat =
            test::image(c.w, c.h, 1, std::vector<float>(std::size_t(c.w) * c.h, 0.0f));
        PreviewOptions o;
        o.normals.convention = NormalConvention::OpenGL;
        const OIIO::ImageBuf sheet = relief::preview(normals, flat, o);
        REQUIRE_FALSE(sheet.has_error());
        const int W = sheet.spec().width, H = sheet.spec().height;
        const std::vector<float> px = test::pixels(sheet);
        const auto at = [&](int x, int y) {
            const float* p = &px[3 * (std::size_t(y) * W + x)];
            return std::array<float, 3>{p[0], p[1], p[2]};
        };
        const auto background = at(0, 0);
        const int cw = std::max(c.pw, 344);
        REQUIRE((W - 3 * cw) % 4 == 0);
        const int margin = (W - 3 * cw) / 4;
        CHECK(margin > 0);
        // One colour over [x0, x0 + pw) of row y, other than the background.
        const auto panel_row = [&](int x0, int y) {
            const auto first = at(x0, y);
            if (first == background)
                return false;
            for (int x = x0; x < x0 + c.pw; ++x)
                if (at(x, y) != first)
                    return false;
            return true;
        };
        std::array<int, 2> top{};
        for (int row = 0; row < 2; ++row)
            for (int col = 0; col < (row == 0 ? 3 : 2); ++col) {
                INFO("panel " << col << "," << row);
                const int x0 = margin + col * (cw + margin);
                int y0 = row == 0 ? 0 : top[0] + c.ph;
                while (y0 < H && !panel_row(x0, y0))
                    ++y0;
                REQUIRE(y0 + c.ph <= H);
                if (col == 0)
                    top[std::size_t(row)] = y0;
                CHECK(y0 == top[std::size_t(row)]);  // a row's panels line up
                const auto colour = at(x0, y0);
                auto& first = unscaled[std::size_t(row * 3 + col)];
                if (&c == &cases[0])
                    first = colour;
                for (int k = 0; k < 3; ++k)
                    CHECK(std::abs(colour[std::size_t(k)] - first[std::size_t(k)]) <= 1e-5f);
                int uniform_rows = 0;
                for (int y = y0; y < y0 + c.ph; ++y)
                    uniform_rows += panel_row(x0, y) && at(x0, y) == colour;
                CHECK(uniform_rows == c.ph);
                CHECK(at(x0 - 1, y0) == background);  // its left, right and lower edges
                CHECK(at(x0 + c.pw, y0 + c.ph - 1) == background);
                CHECK(at(x0 + c.pw / 2, y0 + c.ph) != colour);
                if (row == 1) {  // d and e: a colour bar under the panel, as wide as the cell
                    int bar = y0 + c.ph;
                    while (bar < H && at(x0, bar) == background)
                        ++bar;
                    REQUIRE(bar < H);
                    int coloured = 0;
                    for (int x = x0; x < x0 + cw; ++x)
                        coloured += at(x, bar + 2) != background;
                    CHECK(coloured == cw);
                    CHECK(at(x0 + cw, bar + 2) == background);
                    CHECK(at(x0, bar + 2) != at(x0 + cw - 1, bar + 2));  // a ramp, not one colour
                    // The whole ramp, end to end: d from inferno's black to its
                    // pale yellow, e from viridis's purple to its yellow.
                    using Colour = std::array<float, 3>;
                    const Colour left = col == 0 ? Colour{0.0f, 0.0f, 0.02f} : Colour{0.27f, 0.0f, 0.33f};
                    const Colour right = col == 0 ? Colour{0.99f, 1.0f, 0.64f} : Colour{0.99f, 0.91f, 0.14f};
                    for (int k = 0; k < 3; ++k) {
                        CHECK(std::abs(at(x0, bar + 2)[std::size_t(k)] - left[std::size_t(k)]) <= 1.0f / 255);
                        CHECK(std::abs(at(x0 + cw - 1, bar + 2)[std::size_t(k)] - right[std::size_t(k)]) <=
                              1.0f / 255);
                    }
                    if (col == 1) {  // e: a flat height is its ramp's middle colour
                        const auto middle = at(x0 + cw / 2, bar + 2);
                        for (int k = 0; k < 3; ++k)
                            CHECK(std::abs(colour[std::size_t(k)] - middle[std::size_t(k)]) <= 3.0f / 255);
                    }
                }
            }
        // Two rows of cells with equal margins: H = 2 (row pitch) + margin.
        CHECK(H == 2 * (top[1] - top[0]) + margin);
        CHECK(top[1] - top[0] >= std::max(c.ph, 100) + margin);
    }
}

TEST_CASE("preview: refuses mismatched sizes, bad lights and environments", "[check][preview][errors]")
{
    const fs::path d = test::scratch("check_preview_errors");
    const OIIO::ImageBuf height = test::image(8, 8, 1, std::vector<float>(64, 0.0f));
    const OIIO::ImageBuf normals = relief::normals(height);
    OIIO::ImageBuf out;
    CHECK_FALSE(
        relief::preview(out, relief::normals(test::image(8, 6, 1, std::vector<float>(48, 0.0f))), height));
    CHECK_THAT(geterror(), Catch::Contains("the normal map is 8x6, the height 8x8"));
    PreviewOptions o;
    o.elevation = 0.0f;
    CHECK_FALSE(relief::preview(out, normals, height, o));
    CHECK_THAT(geterror(), Catch::Contains("EL in (0, 90]"));
    std::vector<float> bad(64 * 3, 1.0f);
    bad[7] = NAN;
    REQUIRE(write_image(test::image(8, 8, 3, bad), (d / "env.exr").string()));
    o = PreviewOptions();
    o.env = (d / "env.exr").string();
    CHECK_FALSE(relief::preview(out, normals, height, o));
    CHECK_THAT(geterror(), Catch::Contains("NaN"));
    const std::string in = (d / "n.exr").string(), hf = (d / "h.exr").string();
    REQUIRE(write_image(normals, in));
    REQUIRE(write_image(height, hf));
    for (const std::string& mods :
         {std::string("light=90"), std::string("light=90,0"), std::string("light=400,30"),
          std::string("env=") + (d / "missing.exr").string()}) {
        const auto r =
            run_cli("'" + in + "' '" + hf + "' --preview:" + mods + " -o '" + (d / "s.png").string() + "'");
        INFO(mods << ": " << r.err);
        CHECK(r.rc == 2);
        CHECK_FALSE(fs::exists(d / "s.png"));
    }
}
