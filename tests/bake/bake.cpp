// SPDX-License-Identifier: Apache-2.0
// Baking: the device gather against the golden model, exact zero-offset
// round trips, colour management, seams, and the command line's examples
// and refusals.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "bake/bake_stage.h"
#include "io/colour.h"
#include "device/compute_context.h"
#include "reference/bake_reference.h"
#include "relief/bake.h"
#include "relief/correct.h"
#include "relief/errors.h"
#include "relief/imageio.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/run_cli.h"

using namespace relief;
namespace fs = std::filesystem;
using relief::test::json_number;
using relief::test::random_field;
using relief::test::run_cli;

namespace {

const std::string kData = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01";

OIIO::ImageBuf image(int w, int h, int nch, const std::vector<float>& px)
{
    OIIO::ImageBuf b(OIIO::ImageSpec(w, h, nch, OIIO::TypeDesc::FLOAT));
    b.set_pixels(b.roi(), OIIO::TypeDesc::FLOAT, px.data());
    return b;
}

std::vector<float> pixels(const OIIO::ImageBuf& b)
{
    std::vector<float> v(std::size_t(b.spec().width) * b.spec().height * b.nchannels());
    b.get_pixels(b.roi(), OIIO::TypeDesc::FLOAT, v.data());
    return v;
}

// A black (left) / white (right) RGB edge, and offsets that read half a
// texel to the right: the texel left of the edge gets the mean of 0 and 1.
void edge_shifted_half_a_texel(int w, int h, std::vector<float>& src, std::vector<float>& off)
{
    src.assign(std::size_t(w) * h * 3, 0.0f);
    off.assign(2 * std::size_t(w) * h, 0.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            for (int c = 0; c < 3; ++c)
                src[(std::size_t(y) * w + x) * 3 + c] = x < w / 2 ? 0.0f : 1.0f;
            off[2 * (std::size_t(y) * w + x)] = 0.5f / w;
        }
}

}  // namespace

TEST_CASE("bake: device gather equals the golden model", "[bake]")
{
    const int w = 37, h = 29, nch = 3;
    const auto src = random_field(std::size_t(w) * h * nch, 1, 0.0f, 1.0f);
    const auto off = random_field(2 * std::size_t(w) * h, 2, -0.1f, 0.1f);
    auto ctx = host::ComputeContext::acquire("auto");
    // Both axes, neither, and each alone ("periodic,fixed" offsets).
    for (const host::Periodic periodic : {host::Periodic(true), host::Periodic(false),
                                          host::Periodic(true, false), host::Periodic(false, true)})
        for (bool bicubic : {false, true}) {
            std::vector<float> out(src.size());
            host::bake_gather(*ctx, src.data(), w, h, nch, off.data(), periodic,
                              bicubic ? host::BakeFilter::Bicubic : host::BakeFilter::Bilinear, out.data());
            const auto gold = reference::bake_gather(std::vector<double>(src.begin(), src.end()), w, h, nch,
                                                     std::vector<double>(off.begin(), off.end()), periodic.x,
                                                     periodic.y, bicubic);
            double worst = 0.0;
            for (std::size_t i = 0; i < out.size(); ++i)
                worst = std::max(worst, std::abs(out[i] - gold[i]));
            INFO("periodic x " << periodic.x << " y " << periodic.y << " bicubic " << bicubic);
            CHECK(worst < 2e-5);
        }
}

TEST_CASE("bake: zero offsets give the texture back bit-exactly", "[bake]")
{
    const int w = 23, h = 17;
    const auto src = random_field(std::size_t(w) * h * 4, 3, -2.0f, 5.0f);
    const std::vector<float> zero(2 * std::size_t(w) * h, 0.0f);
    for (auto filter : {BakeFilter::Bilinear, BakeFilter::Bicubic}) {
        BakeOptions o;
        o.filter = filter;
        o.colorspace = BakeColorspace::Raw;
        OIIO::ImageBuf out;
        REQUIRE(bake(out, image(w, h, 4, src), image(w, h, 2, zero), o));
        CHECK(pixels(out) == src);
    }
}

TEST_CASE("bake: sRGB decoding and encoding round-trip", "[bake]")
{
    std::vector<float> px;
    for (int i = 0; i <= 255; ++i)
        px.insert(px.end(), {i / 255.0f, i / 255.0f, 1.0f - i / 255.0f, 0.25f});
    auto lin = px;
    detail::to_linear(lin, 4, "sRGB");
    // IEC 61966-2-1: 0.5 encodes 0.214041; alpha is untouched.
    CHECK(lin[4 * 128] == Approx(std::pow((128 / 255.0 + 0.055) / 1.055, 2.4)).epsilon(1e-5));
    // The linear toe: OCIO makes it meet the curve continuously (slope
    // 12.923 rather than the standard's rounded 12.92).
    CHECK(lin[4 * 5] == Approx(5 / 255.0 / 12.92).epsilon(3e-3));
    CHECK(lin[3] == 0.25f);
    auto back = lin;
    detail::from_linear(back, 4, "sRGB");
    for (std::size_t i = 0; i < px.size(); ++i)
        REQUIRE(std::abs(back[i] - px[i]) < 2e-6);
}

TEST_CASE("bake: colour is filtered in linear light", "[bake]")
{
    // A sharp black/white edge shifted half a texel: the linear mean of 0
    // and 1 is 0.5, which sRGB encodes as 0.735 (not 0.5).
    const int w = 8, h = 4;
    std::vector<float> src, off;
    edge_shifted_half_a_texel(w, h, src, off);
    BakeOptions o;
    o.colorspace = BakeColorspace::SRGB;
    OIIO::ImageBuf out;
    REQUIRE(bake(out, image(w, h, 3, src), image(w, h, 2, off), o));
    const auto px = pixels(out);
    CHECK(px[(w / 2 - 1) * 3] == Approx(1.055 * std::pow(0.5, 1 / 2.4) - 0.055).epsilon(1e-4));
    o.colorspace = BakeColorspace::Raw;
    REQUIRE(bake(out, image(w, h, 3, src), image(w, h, 2, off), o));
    CHECK(pixels(out)[(w / 2 - 1) * 3] == Approx(0.5f));
}

TEST_CASE("bake: periodic seams stay continuous", "[bake]")
{
    // Shifting texture and offsets together shifts the bake exactly.
    const int w = 32, h = 24, sx = 11, sy = 7;
    const auto src = random_field(std::size_t(w) * h, 4, 0.0f, 1.0f);
    const auto off = random_field(2 * std::size_t(w) * h, 5, -0.05f, 0.05f);
    std::vector<float> src2(src.size()), off2(off.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t from = std::size_t((y + sy) % h) * w + (x + sx) % w,
                              to = std::size_t(y) * w + x;
            src2[to] = src[from];
            off2[2 * to] = off[2 * from];
            off2[2 * to + 1] = off[2 * from + 1];
        }
    BakeOptions o;
    o.wrap = BakeWrap::Periodic;
    o.colorspace = BakeColorspace::Raw;
    OIIO::ImageBuf a, b;
    REQUIRE(bake(a, image(w, h, 1, src), image(w, h, 2, off), o));
    REQUIRE(bake(b, image(w, h, 1, src2), image(w, h, 2, off2), o));
    const auto pa = pixels(a), pb = pixels(b);
    double worst = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            worst = std::max(worst, double(std::abs(pb[std::size_t(y) * w + x] -
                                                    pa[std::size_t((y + sy) % h) * w + (x + sx) % w])));
    CHECK(worst < 1e-5);  // texel coordinates i + c w round differently at different i
}

TEST_CASE("bake: normal maps are renormalised, bad input fails cleanly", "[bake]")
{
    const int w = 16, h = 16;
    std::vector<float> nrm(std::size_t(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double a = 0.6 * std::sin(x * 0.9), nx = std::sin(a), nz = std::cos(a);
            float* p = &nrm[(std::size_t(y) * w + x) * 3];
            p[0] = float(0.5 * nx + 0.5);
            p[1] = 0.5f;
            p[2] = float(0.5 * nz + 0.5);
        }
    const auto off = random_field(2 * std::size_t(w) * h, 6, -0.03f, 0.03f);
    BakeOptions o;
    o.kind = BakeKind::Normal;
    OIIO::ImageBuf out;
    OIIO::ImageBuf tex = image(w, h, 3, nrm);
    tex.specmod().attribute("oiio:ColorSpace", "sRGB");  // ignored: normals are data
    REQUIRE(bake(out, image(w, h, 3, nrm), image(w, h, 2, off), o));
    const auto px = pixels(out);
    for (std::size_t i = 0; i < px.size(); i += 3) {
        const double x = px[i], y = px[i + 1], z = px[i + 2];  // float maps: as stored
        REQUIRE(std::abs(std::sqrt(x * x + y * y + z * z) - 1.0) < 1e-5);
    }

    BakeOptions d;
    CHECK_FALSE(bake(out, image(w, h, 3, nrm), image(w + 1, h, 2, std::vector<float>(2 * (w + 1) * h)), d));
    CHECK(geterror().find("offset map is 17x16") != std::string::npos);
    CHECK_FALSE(bake(out, image(w, h, 3, nrm), image(w, h - 1, 2, std::vector<float>(2 * w * (h - 1))), d));
    CHECK(geterror().find("offset map is 16x15, the texture 16x16") != std::string::npos);
    for (float bad : {std::nanf(""), INFINITY, -INFINITY}) {
        auto broken = off;
        broken[37] = bad;
        CHECK_FALSE(bake(out, image(w, h, 3, nrm), image(w, h, 2, broken), d));
        CHECK(geterror().find("the offset map has NaN or infinite values") != std::string::npos);
    }
    CHECK_FALSE(bake(out, image(w, h, 3, nrm), image(w, h, 1, std::vector<float>(w * h)), d));
    CHECK(geterror().find("channel") != std::string::npos);
    d.kind = BakeKind::Height;
    CHECK_FALSE(bake(out, image(w, h, 1, std::vector<float>(w * h)), image(w, h, 2, off), d));
    CHECK(geterror().find("displacement") != std::string::npos);
}

namespace {

// Unit direction of a normal stored as UNORM ([0, 1]) or signed values.
template <class T>
std::array<double, 3> direction(const T* v, bool unorm)
{
    std::array<double, 3> n;
    double len = 0.0;
    for (int c = 0; c < 3; ++c) {
        n[c] = unorm ? 2.0 * v[c] - 1.0 : v[c];
        len += n[c] * n[c];
    }
    len = std::sqrt(len);
    for (double& x : n)
        x /= len;
    return n;
}

// The largest angle (radians) between the baked normals and the golden
// gather's, renormalised; `length_error` gets the largest ||n| - 1| of the
// baked ones (they are renormalised).
double worst_normal_angle(const std::vector<float>& baked, const std::vector<double>& gold, int nch,
                          bool unorm, double& length_error)
{
    double worst = 0.0;
    length_error = 0.0;
    for (std::size_t i = 0; i < baked.size(); i += nch) {
        const auto a = direction(&baked[i], unorm);
        const auto b = direction(&gold[i], unorm);
        double len = 0.0;
        for (int c = 0; c < 3; ++c) {
            const double v = unorm ? 2.0 * baked[i + c] - 1.0 : baked[i + c];
            len += v * v;
        }
        length_error = std::max(length_error, std::abs(std::sqrt(len) - 1.0));
        const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        worst = std::max(worst, std::acos(std::min(1.0, dot)));
    }
    return worst;
}

// A bumpy tangent-space normal map (unit vectors, +z up), OpenGL.
OIIO::ImageBuf bumpy_normals(int w, int h, OIIO::TypeDesc type, int nch = 3)
{
    const test::PeriodicField f{w, h, {{1, 1, 3.0, 0.4}, {3, -2, 1.0, 1.1}}};
    return test::normal_image(f.slopes(), w, h, test::Green::OpenGL, type, nch);
}

}  // namespace

TEST_CASE("bake: 8- and 16-bit normal maps bake to the golden gather's directions", "[bake]")
{
    const int w = 24, h = 20;
    const auto off = random_field(2 * std::size_t(w) * h, 12, -0.06f, 0.06f);
    for (OIIO::TypeDesc type : {OIIO::TypeDesc::UINT8, OIIO::TypeDesc::UINT16})
        for (int nch : {3, 4})
            for (bool periodic : {true, false}) {
                INFO(type << " " << nch << " channels, periodic " << periodic);
                const OIIO::ImageBuf tex = bumpy_normals(w, h, type, nch);
                const auto src = pixels(tex);
                BakeOptions o;  // kind=auto: recognised as a normal map by its texels
                o.wrap = periodic ? BakeWrap::Periodic : BakeWrap::Clamp;
                std::string said;
                o.exec.on_message = [&](Severity, const std::string& m) { said += m; };
                OIIO::ImageBuf out;
                REQUIRE(bake(out, tex, image(w, h, 2, off), o));
                CHECK(said.find("normal map") != std::string::npos);
                CHECK(out.spec().get_string_attribute("relief:native_format") == type.c_str());
                const auto got = pixels(out);
                const auto gold = reference::bake_gather(std::vector<double>(src.begin(), src.end()), w, h,
                                                         nch, std::vector<double>(off.begin(), off.end()),
                                                         periodic, periodic, false);
                double length_error = 0.0;
                CHECK(worst_normal_angle(got, gold, nch, true, length_error) < 1e-5);
                CHECK(length_error < 1e-5);
                if (nch == 4)  // alpha is filtered, not renormalised
                    for (std::size_t i = 3; i < got.size(); i += 4)
                        REQUIRE(std::abs(got[i] - gold[i]) < 1e-5);
            }
}

TEST_CASE("bake: half and float normal maps (signed) bake to the golden gather's directions", "[bake]")
{
    const int w = 24, h = 20;
    const auto off = random_field(2 * std::size_t(w) * h, 14, -0.06f, 0.06f);
    for (OIIO::TypeDesc type : {OIIO::TypeDesc::HALF, OIIO::TypeDesc::FLOAT}) {
        INFO(type);
        const OIIO::ImageBuf tex = bumpy_normals(w, h, type);
        const auto src = pixels(tex);
        BakeOptions o;
        o.kind = BakeKind::Normal;
        o.wrap = BakeWrap::Periodic;
        OIIO::ImageBuf out;
        REQUIRE(bake(out, tex, image(w, h, 2, off), o));
        const auto gold =
            reference::bake_gather(std::vector<double>(src.begin(), src.end()), w, h, 3,
                                   std::vector<double>(off.begin(), off.end()), true, true, false);
        double length_error = 0.0;
        CHECK(worst_normal_angle(pixels(out), gold, 3, false, length_error) < 1e-5);
        CHECK(length_error < 1e-5);
    }
}

TEST_CASE("bake: colorspace=auto decodes 8-bit PNGs as sRGB, floats as linear", "[bake][colour]")
{
    const auto dir = relief::test::scratch("bake/auto_space");
    const int w = 16, h = 12;
    const auto src = random_field(std::size_t(w) * h * 3, 21, 0.0f, 1.0f);
    const auto off = random_field(2 * std::size_t(w) * h, 22, -0.1f, 0.1f);
    struct Case {
        const char* file;
        OIIO::TypeDesc type;
        BakeColorspace same_as;
    };
    for (const Case& c : {Case{"albedo.png", OIIO::TypeDesc::UINT8, BakeColorspace::SRGB},
                          Case{"albedo16.png", OIIO::TypeDesc::UINT16, BakeColorspace::SRGB},
                          Case{"albedo.tif", OIIO::TypeDesc::UINT8, BakeColorspace::SRGB},
                          Case{"albedo.exr", OIIO::TypeDesc::FLOAT, BakeColorspace::Linear}}) {
        INFO(c.file);
        REQUIRE(image(w, h, 3, src).write((dir / c.file).string(), c.type));
        OIIO::ImageBuf tex;
        REQUIRE(relief::read_image(tex, (dir / c.file).string()));
        auto baked = [&](BakeColorspace cs) {
            BakeOptions o;
            o.kind = BakeKind::Color;
            o.colorspace = cs;
            OIIO::ImageBuf out;
            REQUIRE(bake(out, tex, image(w, h, 2, off), o));
            return pixels(out);
        };
        const auto automatic = baked(BakeColorspace::Auto);
        const BakeColorspace other =
            c.same_as == BakeColorspace::SRGB ? BakeColorspace::Linear : BakeColorspace::SRGB;
        CHECK(automatic == baked(c.same_as));
        CHECK(test::max_abs_diff(automatic, baked(other)) > 1e-3);
    }
}

TEST_CASE("bake: wrap=auto wraps when the offsets say periodic", "[bake]")
{
    const int w = 20, h = 14;
    const auto src = random_field(std::size_t(w) * h, 31, 0.0f, 1.0f);
    const auto off = random_field(2 * std::size_t(w) * h, 32, -0.15f, 0.15f);
    auto baked = [&](BakeWrap wrap, const char* boundary) {
        BakeOptions o;
        o.colorspace = BakeColorspace::Raw;
        o.wrap = wrap;
        OIIO::ImageBuf offsets = image(w, h, 2, off);
        if (boundary)
            offsets.specmod().attribute("relief:boundary", boundary);
        OIIO::ImageBuf out;
        REQUIRE(bake(out, image(w, h, 1, src), offsets, o));
        return pixels(out);
    };
    const auto periodic = baked(BakeWrap::Periodic, nullptr), clamp = baked(BakeWrap::Clamp, nullptr);
    CHECK(test::max_abs_diff(periodic, clamp) > 1e-3);
    CHECK(baked(BakeWrap::Auto, "periodic") == periodic);
    CHECK(baked(BakeWrap::Auto, "fixed") == clamp);
    CHECK(baked(BakeWrap::Auto, nullptr) == clamp);
    CHECK(baked(BakeWrap::Clamp, "periodic") == clamp);  // an explicit choice wins
    // Per axis, as --correct:boundary=periodic,fixed writes it: the device
    // wrapping x and clamping y, which neither single choice gives.
    auto ctx = host::ComputeContext::acquire("auto");
    for (const auto& [boundary, axes] : {std::pair{"periodic,fixed", host::Periodic(true, false)},
                                         std::pair{"fixed,periodic", host::Periodic(false, true)}}) {
        INFO(boundary);
        std::vector<float> want(src.size());
        host::bake_gather(*ctx, src.data(), w, h, 1, off.data(), axes, host::BakeFilter::Bilinear,
                          want.data());
        const auto got = baked(BakeWrap::Auto, boundary);
        CHECK(got == want);
        CHECK(test::max_abs_diff(got, periodic) > 1e-3);
        CHECK(test::max_abs_diff(got, clamp) > 1e-3);
    }
}

TEST_CASE("bake: kind=auto tells normal and height maps by name and by origin", "[bake]")
{
    const auto dir = relief::test::scratch("bake/kinds");
    const int w = 12, h = 10;
    const auto noise = random_field(std::size_t(w) * h * 3, 61, 0.0f, 1.0f);
    const auto off = image(w, h, 2, random_field(2 * std::size_t(w) * h, 62, -0.05f, 0.05f));
    auto kind_of = [&](const OIIO::ImageBuf& tex) {
        std::string said;
        BakeOptions o;
        o.exec.on_message = [&](Severity, const std::string& m) { said += m; };
        OIIO::ImageBuf out;
        if (!bake(out, tex, off, o))
            return std::string("refused: ") + geterror();
        return said;
    };
    auto read_back = [&](const std::string& name, int nch, const std::vector<float>& px) {
        REQUIRE(image(w, h, nch, px).write((dir / name).string(), OIIO::TypeDesc::UINT8));
        OIIO::ImageBuf b;
        REQUIRE(relief::read_image(b, (dir / name).string()));
        return b;
    };
    // Noise named like a normal map bakes as one; named otherwise, as colour.
    CHECK(kind_of(read_back("brick_nrm.png", 3, noise)).find("as normal map") != std::string::npos);
    CHECK(kind_of(read_back("brick_Normal.png", 3, noise)).find("as normal map") != std::string::npos);
    CHECK(kind_of(read_back("brick_albedo.png", 3, noise)).find("as colour") != std::string::npos);
    // One-channel maps named like heights, and relief's own heights, are refused.
    const std::vector<float> one(noise.begin(), noise.begin() + w * h);
    for (const char* name : {"rock_height.png", "rock_disp.png", "rock_bump.png", "rock_depth.png"}) {
        INFO(name);
        CHECK(kind_of(read_back(name, 1, one)).find("refused: bake: refusing to bake a displacement") == 0);
    }
    CHECK(kind_of(read_back("rock_roughness.png", 1, one)).find("as colour") != std::string::npos);
    OIIO::ImageBuf own = image(w, h, 1, one);
    for (const char* method : {"poisson", "rays"}) {
        own.specmod().attribute("relief:method", method);
        CHECK(kind_of(own).find("refused") == 0);
    }
}

TEST_CASE("cli: bake uses the OCIO config named by $OCIO", "[cli][bake][colour]")
{
    // A config whose "sRGB" is a plain gamma 2 curve: a half-texel shift of
    // a black/white edge gives sqrt(0.5) = 0.7071 (180 of 255) with it and
    // 0.7354 (188) with the built-in sRGB curve.
    const auto dir = relief::test::scratch("bake/ocio");
    std::ofstream(dir / "config.ocio") << R"(ocio_profile_version: 2
roles:
  default: linear
  scene_linear: linear
  data: raw
file_rules:
  - !<Rule> {name: Default, colorspace: default}
displays:
  sRGB:
    - !<View> {name: Raw, colorspace: raw}
active_displays: []
active_views: []
colorspaces:
  - !<ColorSpace>
    name: linear
  - !<ColorSpace>
    name: raw
    isdata: true
  - !<ColorSpace>
    name: sRGB
    to_scene_reference: !<ExponentTransform> {value: 2.0}
)";
    const int w = 8, h = 4;
    std::vector<float> src, off;
    edge_shifted_half_a_texel(w, h, src, off);
    REQUIRE(image(w, h, 3, src).write((dir / "albedo.png").string(), OIIO::TypeDesc::UINT8));
    REQUIRE(image(w, h, 2, off).write((dir / "offsets.exr").string()));
    const std::string args = "'" + (dir / "albedo.png").string() + "' '" + (dir / "offsets.exr").string() +
                             "' --bake:kind=color -o '";
    for (const auto& [env, code] :
         {std::pair{std::string("OCIO='") + (dir / "config.ocio").string() + "'", 180},
          std::pair{std::string("OCIO="), 188}}) {
        INFO(env);
        auto r = run_cli(args + (dir / "out.png").string() + "'", env);
        INFO(r.err);
        REQUIRE(r.rc == 0);
        CHECK(r.err.find(code == 180 ? "OCIO config" : "raw config") != std::string::npos);
        const auto px = test::file_pixels(dir / "out.png");
        REQUIRE(px.size() == src.size());
        CHECK(std::lround(px[(w / 2 - 1) * 3] * 255.0f) == code);
        CHECK(px[0] == 0.0f);
        CHECK(px[(w - 1) * 3] == 1.0f);
    }
}

TEST_CASE("bake: a declared colour space needs a config that has it", "[bake][colour]")
{
    const int w = 4, h = 4;
    OIIO::ImageBuf tex = image(w, h, 3, random_field(std::size_t(w) * h * 3, 51, 0.0f, 1.0f));
    tex.specmod().attribute("oiio:ColorSpace", "ACEScg");
    BakeOptions o;
    o.kind = BakeKind::Color;
    OIIO::ImageBuf out;
    CHECK_FALSE(bake(out, tex, image(w, h, 2, std::vector<float>(2 * w * h, 0.01f)), o));
    CHECK(geterror().find("'ACEScg' needs an OCIO config") != std::string::npos);
    tex.specmod().attribute("oiio:ColorSpace", "scene_linear");
    REQUIRE(bake(out, tex, image(w, h, 2, std::vector<float>(2 * w * h, 0.0f)), o));
    CHECK(pixels(out) == pixels(tex));
}

TEST_CASE("cli: a baked 8-bit normal map keeps its type and the golden directions", "[cli][bake]")
{
    const auto dir = relief::test::scratch("bake/normal_png");
    const int w = 32, h = 24;
    REQUIRE(bumpy_normals(w, h, OIIO::TypeDesc::UINT8).write((dir / "wall_normal.png").string()));
    const auto off = random_field(2 * std::size_t(w) * h, 41, -0.05f, 0.05f);
    OIIO::ImageBuf offsets = image(w, h, 2, off);
    offsets.specmod().attribute("relief:boundary", "periodic");
    REQUIRE(offsets.write((dir / "offsets.exr").string()));
    auto r = run_cli("'" + (dir / "wall_normal.png").string() + "' '" + (dir / "offsets.exr").string() +
                     "' --bake -o '" + (dir / "baked.png").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    OIIO::ImageBuf baked((dir / "baked.png").string());
    REQUIRE(baked.read(0, 0, true, OIIO::TypeDesc::FLOAT));
    CHECK(baked.nativespec().format == OIIO::TypeDesc::UINT8);
    const auto src = test::file_pixels(dir / "wall_normal.png");
    const auto gold = reference::bake_gather(std::vector<double>(src.begin(), src.end()), w, h, 3,
                                             std::vector<double>(off.begin(), off.end()), true, true, false);
    // 8-bit storage: within about one code of the direction.
    double length_error = 0.0;
    CHECK(worst_normal_angle(pixels(baked), gold, 3, true, length_error) < 0.02);
    CHECK(length_error < 2.0 / 255.0);
}

namespace {

OIIO::ImageBuf read(const std::string& path)
{
    OIIO::ImageBuf b;
    REQUIRE(relief::read_image(b, path));
    return b;
}

}  // namespace

TEST_CASE("cli: correct and bake, the documented examples, equal the API's results", "[cli][bake][slow]")
{
    auto dir = relief::test::scratch("bake/examples");
    const std::string height = kData + "/height.png", normal = kData + "/normal.png";
    // The first example, with a report.
    auto r = run_cli("'" + height + "' --correct:scale=0.05:theta=5:nodes=center:boundary=periodic -o '" +
                     (dir / "offsets.exr").string() + "' --report '" + (dir / "report.json").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    OIIO::ImageBuf off((dir / "offsets.exr").string());
    REQUIRE(off.read());
    CHECK(off.spec().nchannels == 2);
    CHECK(off.spec().format == OIIO::TypeDesc::FLOAT);
    CHECK(off.spec().get_string_attribute("relief:boundary") == "periodic");
    CorrectOptions co;
    co.scale = 0.05f;
    co.theta = 5.0f;
    co.nodes = CorrectNodes::Center;
    co.boundary = CorrectBoundary::Periodic;
    CorrectReport rep;
    co.report = &rep;
    const OIIO::ImageBuf api_off = relief::correct(read(height), co);
    REQUIRE_FALSE(api_off.has_error());
    CHECK(test::max_abs_diff(pixels(off), pixels(api_off)) == 0.0);
    const std::string json = relief::test::slurp(dir / "report.json");
    for (const char* key : {"\"anisotropy\"", "\"area_ratio\"", "\"p95\"", "\"seconds\""})
        CHECK(json.find(key) != std::string::npos);
    CHECK(json_number(json, "energy_before") == Approx(rep.energy_before).epsilon(1e-8));
    CHECK(json_number(json, "energy_after") == Approx(rep.energy_after).epsilon(1e-8));
    CHECK(json_number(json, "energy_after") < json_number(json, "energy_before"));
    CHECK(json_number(json, "iterations") == rep.iterations);
    CHECK(rep.iterations > 0);
    CHECK(json_number(json, "width") == 512);
    CHECK(json.find("\"nodes\": \"center\"") != std::string::npos);
    CHECK(json.find("\"boundary\": \"periodic\"") != std::string::npos);

    // The second: a colour texture baked through the offsets, kept 8-bit.
    // (The metal set's normal map stands in for an albedo: 3 channels,
    // colorspace forced to sRGB, kind forced to colour.)
    r = run_cli("'" + normal + "' '" + height + "' --correct:scale=0.05:nodes=center -o '" +
                (dir / "off2.exr").string() + "' --bake:filter=bilinear:colorspace=sRGB:kind=color -o '" +
                (dir / "albedo_fixed.png").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    OIIO::ImageBuf baked((dir / "albedo_fixed.png").string());
    REQUIRE(baked.read(0, 0, true, OIIO::TypeDesc::FLOAT));
    CHECK(baked.nativespec().format == OIIO::TypeDesc::UINT8);
    CHECK(baked.spec().width == 512);
    CorrectOptions c2;
    c2.scale = 0.05f;
    c2.nodes = CorrectNodes::Center;
    const OIIO::ImageBuf off2 = relief::correct(read(height), c2);
    CHECK(test::max_abs_diff(pixels(off2), test::file_pixels(dir / "off2.exr")) == 0.0);
    BakeOptions bo;
    bo.filter = BakeFilter::Bilinear;
    bo.colorspace = BakeColorspace::SRGB;
    bo.kind = BakeKind::Color;
    const OIIO::ImageBuf api_baked = relief::bake(read(normal), off2, bo);
    REQUIRE_FALSE(api_baked.has_error());
    const auto want = pixels(api_baked), got = pixels(baked);
    CHECK(test::max_abs_diff(got, want) <= 0.5 / 255.0 + 1e-6);                // 8-bit rounding only
    CHECK(test::max_abs_diff(got, test::file_pixels(normal)) > 10.0 / 255.0);  // it moved

    // Zero offsets bake an 8-bit texture back exactly.
    r = run_cli("'" + normal + "' '" + height + "' --correct:scale=1e-9 --bake:kind=color -o '" +
                (dir / "same.png").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("nothing to correct") != std::string::npos);
    OIIO::ImageBuf a(normal), b((dir / "same.png").string());
    auto cmp = OIIO::ImageBufAlgo::compare(a, b, 0.0f, 0.0f);
    CHECK(cmp.maxerror == 0.0);
}

TEST_CASE("cli: correct and bake refuse bad input and leave nothing behind", "[cli][bake]")
{
    auto dir = relief::test::scratch("bake/bad");
    const std::string height = kData + "/height.png", normal = kData + "/normal.png";
    const std::string out = (dir / "o.exr").string();
    auto r = run_cli("'" + height + "' --correct:scale=0 -o '" + out + "'");
    CHECK(r.rc != 0);
    CHECK(r.err.find("scale") != std::string::npos);
    r = run_cli("'" + height + "' --correct -o '" + out + "'");  // no scale, not relief's own height
    CHECK(r.rc != 0);
    CHECK(r.err.find("scale") != std::string::npos);
    // ... and a failed correction writes no report.
    r = run_cli("'" + height + "' --correct --report '" + (dir / "r.json").string() + "' -o '" + out + "'");
    CHECK(r.rc == 1);
    CHECK(r.err.find("relief: error: correct: give the displacement scale") != std::string::npos);
    r = run_cli("'" + height + "' --correct:scale=0.05:theta=30 -o '" + out + "'");
    CHECK(r.rc == 2);
    r = run_cli("'" + height + "' --correct:scale=0.05:fix=height:0.5 -o '" + out + "'");
    CHECK(r.rc == 2);
    // Baking the height map through its own offsets is refused.
    r = run_cli("'" + height + "' '" + height + "' --correct:scale=0.05 --bake -o '" + out + "'");
    CHECK(r.rc != 0);
    CHECK(r.err.find("displacement") != std::string::npos);
    // A one-channel "offset map".
    r = run_cli("'" + normal + "' '" + height + "' --bake -o '" + out + "'");
    CHECK(r.rc != 0);
    CHECK(r.err.find("2 (du, dv") != std::string::npos);
    r = run_cli("'" + height + "' --correct:scale=0.05 --report '" + (dir / "r.json").string() +
                "' --correct:scale=0.1 -o '" + out + "'");
    CHECK(r.rc == 2);
    CHECK(fs::is_empty(dir));
}

TEST_CASE("bake: a 3-channel map is offsets only when relief says so", "[bake][errors]")
{
    // A normal map passed as the offset map by mistake must be refused, not
    // read as (du, dv).
    OIIO::ImageBuf tex(OIIO::ImageSpec(8, 8, 3, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(tex, {0.2f, 0.4f, 0.6f});
    OIIO::ImageBuf normals(OIIO::ImageSpec(8, 8, 3, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(normals, {0.0f, 0.0f, 1.0f});
    OIIO::ImageBuf out;
    CHECK_FALSE(relief::bake(out, tex, normals));
    CHECK(relief::geterror().find("the offset map has 3 channel(s); it needs 2") != std::string::npos);
    // The same pixels marked as relief's correction output are accepted.
    normals.specmod().attribute("relief:method", "correct");
    CHECK(relief::bake(out, tex, normals));
}

TEST_CASE("bake: a texture larger than one device buffer goes one channel at a time, same bits", "[bake]")
{
    // 37 x 29 x 4 floats = 17168 bytes; the offsets take 8584. A cap between
    // them makes the gather run per channel plane.
    const int w = 37, h = 29, nch = 4;
    const auto src = random_field(std::size_t(w) * h * nch, 3, 0.0f, 1.0f);
    const auto off = random_field(2 * std::size_t(w) * h, 4, -0.1f, 0.1f);
    auto ctx = host::ComputeContext::acquire("auto");
    for (bool bicubic : {false, true}) {
        INFO("bicubic " << bicubic);
        const auto filter = bicubic ? host::BakeFilter::Bicubic : host::BakeFilter::Bilinear;
        std::vector<float> whole(src.size()), planes(src.size());
        host::bake_gather(*ctx, src.data(), w, h, nch, off.data(), true, filter, whole.data());
        ::setenv("RELIEF_DEVICE_MAX_ALLOC", "10000", 1);
        try {
            host::bake_gather(*ctx, src.data(), w, h, nch, off.data(), true, filter, planes.data());
        } catch (...) {
            ::unsetenv("RELIEF_DEVICE_MAX_ALLOC");
            throw;
        }
        ::unsetenv("RELIEF_DEVICE_MAX_ALLOC");
        CHECK(whole == planes);
    }
}
