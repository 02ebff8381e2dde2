// SPDX-License-Identifier: Apache-2.0
// DDM derivation: the kernel against analytic slopes and the C++ reference.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "reference/ddm_reference.h"
#include "relief/relief.h"
#include "support/fields.h"
#include "support/images.h"

using namespace relief;
using OIIO::TypeDesc;
using relief::test::Green;

namespace {

const test::PeriodicField kField{96, 64, {{1, 0, 3.0, 0.3}, {2, 3, 1.5, 1.1}, {-3, 1, 0.8, 2.0}}};

std::vector<float> pixels(const OIIO::ImageBuf& img)
{
    std::vector<float> v(img.spec().image_pixels() * img.spec().nchannels);
    img.get_pixels(img.roi(), TypeDesc::FLOAT, v.data());
    return v;
}

SlopeOptions with(NormalConvention c)
{
    SlopeOptions o;
    o.normals.convention = c;
    return o;
}

// max |a - b|
double max_diff(const std::vector<float>& a, const std::vector<double>& b)
{
    double m = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        m = std::max(m, std::abs(double(a[i]) - b[i]));
    return m;
}

}  // namespace

TEST_CASE("slopes of an analytic field are exact for float normals, both conventions", "[ddm]")
{
    const auto g = kField.slopes();
    for (auto [green, conv] : {std::pair{Green::OpenGL, NormalConvention::OpenGL},
                               std::pair{Green::DirectX, NormalConvention::DirectX}}) {
        auto img = test::normal_image(g, kField.width, kField.height, green, TypeDesc::FLOAT);
        auto out = relief::slopes(img, with(conv));
        REQUIRE_FALSE(out.has_error());
        REQUIRE(out.spec().nchannels == 2);
        CHECK(max_diff(pixels(out), g) < 2e-5);
        CHECK(out.spec().get_string_attribute("relief:normal_convention") ==
              (green == Green::OpenGL ? "opengl" : "directx"));
    }
}

TEST_CASE("every encoding decodes like the reference and within its quantisation", "[ddm]")
{
    const auto g = kField.slopes();
    struct Case {
        const char* name;
        TypeDesc type;
        int channels;
        bool unsigned_float;
        double analytic_tolerance;  // slope error from storing the normal
    };
    const Case cases[] = {
        {"float RGB", TypeDesc::FLOAT, 3, false, 2e-5},
        {"float RGBA", TypeDesc::FLOAT, 4, false, 2e-5},
        {"float XY", TypeDesc::FLOAT, 2, false, 1e-4},
        {"float RGB in [0,1]", TypeDesc::FLOAT, 3, true, 2e-5},
        {"half RGB in [0,1]", TypeDesc::HALF, 3, true, 2e-2},
        {"half RGB", TypeDesc::HALF, 3, false, 1e-2},
        {"uint16 RGB", TypeDesc::UINT16, 3, false, 1e-3},
        {"uint8 RGB", TypeDesc::UINT8, 3, false, 0.15},
        {"uint8 XY", TypeDesc::UINT8, 2, false, 0.3},
    };
    for (const Case& c : cases) {
        INFO(c.name);
        auto img = test::normal_image(g, kField.width, kField.height, Green::OpenGL, c.type, c.channels,
                                      c.unsigned_float);
        SlopeOptions o = with(NormalConvention::OpenGL);
        if (c.unsigned_float)
            o.normals.float_encoding = FloatEncoding::Unsigned;
        auto out = relief::slopes(img, o);
        REQUIRE_FALSE(out.has_error());
        auto got = pixels(out);

        // The reference decodes the very values stored in the image.
        const int used = std::min(c.channels, 3);
        std::vector<float> stored(std::size_t(kField.width) * kField.height * used);
        OIIO::ROI roi = img.roi();
        roi.chend = used;
        img.get_pixels(roi, TypeDesc::FLOAT, stored.data());
        const bool decode =
            c.type.basetype == TypeDesc::UINT8 || c.type.basetype == TypeDesc::UINT16 || c.unsigned_float;
        const double band = c.type.basetype == TypeDesc::UINT8    ? 1.0 / 255.0
                            : c.type.basetype == TypeDesc::UINT16 ? 1.0 / 65535.0
                                                                  : 0.0;
        auto ref =
            reference::ddm(stored, used, decode ? 2.0 : 1.0, decode ? -1.0 : 0.0, -1.0, 85.0, band * 1.001);
        double worst_rel = 0;
        for (std::size_t i = 0; i < got.size(); ++i)
            worst_rel =
                std::max(worst_rel, std::abs(got[i] - ref.slopes[i]) / (1.0 + std::abs(ref.slopes[i])));
        CHECK(worst_rel < 1e-5);
        CHECK(max_diff(got, g) < c.analytic_tolerance);
    }
}

TEST_CASE("auto finds the convention of a flipped map and reports both curl norms", "[ddm]")
{
    const auto g = kField.slopes();
    for (Green green : {Green::OpenGL, Green::DirectX}) {
        auto img = test::normal_image(g, kField.width, kField.height, green, TypeDesc::UINT8);
        std::vector<std::string> notices, warnings;
        SlopeOptions o = with(NormalConvention::Auto);
        o.exec.on_message = [&](Severity s, const std::string& m) {
            if (s != Severity::Info)
                (s == Severity::Warning ? warnings : notices).push_back(m);
        };
        auto out = relief::slopes(img, o);
        REQUIRE_FALSE(out.has_error());
        const std::string want = green == Green::OpenGL ? "opengl" : "directx";
        CHECK(out.spec().get_string_attribute("relief:normal_convention") == want);
        float gl = out.spec().get_float_attribute("relief:curl_opengl");
        float dx = out.spec().get_float_attribute("relief:curl_directx");
        CHECK((green == Green::OpenGL ? dx / gl : gl / dx) > 3.0f);
        CHECK(warnings.empty());
        bool reported = false;
        for (const auto& m : notices)
            reported |= m.find("normal convention: " + want) != std::string::npos;
        CHECK(reported);
        // The chosen field is the one that matches the analytic slopes.
        CHECK(max_diff(pixels(out), g) < 0.15);

        // The kernel's curl norm agrees with the reference's.
        auto ref_curl =
            reference::curl_rms(reference::ddm(pixels(img), 3, 2.0, -1.0, -1.0, 85.0, 1.001 / 255.0).slopes,
                                kField.width, kField.height);
        CHECK(gl == Approx(ref_curl).epsilon(1e-3));
    }
}

TEST_CASE("auto on a map without curl information warns and falls back to OpenGL", "[ddm]")
{
    std::vector<double> flat(2 * 32 * 32, 0.0);
    auto img = test::normal_image(flat, 32, 32, Green::DirectX, TypeDesc::FLOAT);
    int warnings = 0;
    SlopeOptions o;
    o.exec.on_message = [&](Severity s, const std::string& m) {
        if (s == Severity::Warning) {
            ++warnings;
            CHECK(m.find("ambiguous") != std::string::npos);
        }
    };
    auto out = relief::slopes(img, o);
    REQUIRE_FALSE(out.has_error());
    CHECK(warnings == 1);
    CHECK(out.spec().get_string_attribute("relief:normal_convention") == "opengl");
}

TEST_CASE("NaN, Inf and zero-length normals become flat, are counted, warn once", "[ddm]")
{
    const int w = 16, h = 8;
    std::vector<float> px(std::size_t(w) * h * 3);
    for (std::size_t i = 0; i < px.size(); i += 3) {
        px[i] = 0.3f;
        px[i + 1] = -0.2f;
        px[i + 2] = 0.9f;
    }
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    px[3 * 5 + 0] = nan;
    px[3 * 17 + 2] = inf;
    px[3 * 40 + 0] = px[3 * 40 + 1] = px[3 * 40 + 2] = 0.0f;
    px[3 * 41 + 0] = px[3 * 41 + 1] = 0.0f;  // straight down: no tilt direction
    px[3 * 41 + 2] = -1.0f;
    OIIO::ImageBuf img(OIIO::ImageSpec(w, h, 3, TypeDesc::FLOAT));
    img.set_pixels(img.roi(), TypeDesc::FLOAT, px.data());

    int warnings = 0;
    SlopeOptions o = with(NormalConvention::OpenGL);
    o.exec.on_message = [&](Severity s, const std::string&) { warnings += s == Severity::Warning; };
    auto out = relief::slopes(img, o);
    REQUIRE_FALSE(out.has_error());
    CHECK(warnings == 1);
    CHECK(out.spec().get_int_attribute("relief:invalid_normals") == 4);
    auto g = pixels(out);
    for (float v : g)
        CHECK(std::isfinite(v));
    for (int t : {5, 17, 40, 41}) {
        CHECK(g[2 * t] == 0.0f);
        CHECK(g[2 * t + 1] == 0.0f);
    }
}

TEST_CASE("grazing normals are clamped to max_angle keeping their azimuth", "[ddm]")
{
    // nz -> 0 along a direction (3, 4): slope magnitude must be tan(max_angle).
    std::vector<float> px = {0.6f, 0.8f, 0.0f, 0.6f, 0.8f, 1e-4f, -0.6f, 0.8f, -0.2f, 0.0f, 0.0f, 1.0f};
    OIIO::ImageBuf img(OIIO::ImageSpec(4, 1, 3, TypeDesc::FLOAT));
    img.set_pixels(img.roi(), TypeDesc::FLOAT, px.data());
    for (float angle : {85.0f, 60.0f}) {
        SlopeOptions o = with(NormalConvention::DirectX);
        o.normals.max_angle = angle;
        auto out = relief::slopes(img, o);
        REQUIRE_FALSE(out.has_error());
        CHECK(out.spec().get_int_attribute("relief:clamped_normals") == 3);
        auto g = pixels(out);
        const double t = std::tan(angle * M_PI / 180.0);
        for (int i = 0; i < 3; ++i) {
            CHECK(std::hypot(g[2 * i], g[2 * i + 1]) == Approx(t).epsilon(1e-5));
            // The azimuth stays: DirectX rows point along +G, so
            // g = -(R, G) / nz points along -(R, G).
            const double r = px[3 * i], gr = px[3 * i + 1], len = std::hypot(r, gr);
            CHECK(g[2 * i] / t == Approx(-r / len).margin(1e-5));
            CHECK(g[2 * i + 1] / t == Approx(-gr / len).margin(1e-5));
        }
        CHECK(g[6] == 0.0f);
        CHECK(g[7] == 0.0f);
    }
}

TEST_CASE("unsupported channel counts and empty images fail cleanly", "[ddm][errors]")
{
    for (int channels : {1, 5}) {
        OIIO::ImageBuf img(OIIO::ImageSpec(8, 8, channels, TypeDesc::FLOAT));
        OIIO::ImageBuf out;
        CHECK_FALSE(relief::slopes(out, img));
        CHECK(relief::geterror().find("channel count " + std::to_string(channels)) != std::string::npos);
    }
    OIIO::ImageBuf empty, out;
    CHECK_FALSE(relief::slopes(out, empty));
    CHECK_FALSE(relief::geterror().empty());
}

TEST_CASE("an ROI gives the same slopes as the whole image over that region", "[ddm]")
{
    const auto g = kField.slopes();
    auto img = test::normal_image(g, kField.width, kField.height, Green::OpenGL, TypeDesc::FLOAT);
    OIIO::ROI roi(10, 40, 5, 25);
    auto part = relief::slopes(img, with(NormalConvention::OpenGL), roi);
    REQUIRE_FALSE(part.has_error());
    CHECK(part.spec().width == 30);
    CHECK(part.spec().height == 20);
    CHECK(part.spec().x == 10);
    CHECK(part.spec().y == 5);
    CHECK(part.spec().channelnames == std::vector<std::string>{"gx", "gy"});
    auto got = pixels(part);
    for (int y = 0; y < 20; ++y)
        for (int x = 0; x < 30; ++x)
            for (int c = 0; c < 2; ++c)
                CHECK(std::abs(got[2 * (y * 30 + x) + c] - g[2 * ((y + 5) * kField.width + x + 10) + c]) <
                      2e-5);
}

TEST_CASE("8- and 16-bit flat codes decode to exactly zero slope", "[ddm]")
{
    // 127 and 128 of 255 sit half a code either side of 0; neither is a tilt.
    for (auto type : {TypeDesc::UINT8, TypeDesc::UINT16}) {
        const float lo = type == TypeDesc::UINT8 ? 127.0f / 255.0f : 32767.0f / 65535.0f;
        const float hi = type == TypeDesc::UINT8 ? 128.0f / 255.0f : 32768.0f / 65535.0f;
        OIIO::ImageBuf img(OIIO::ImageSpec(4, 1, 3, type));
        const float px[4][3] = {{lo, lo, 1}, {hi, hi, 1}, {lo, hi, 1}, {hi, 0.75f, 1}};
        for (int x = 0; x < 4; ++x)
            img.setpixel(x, 0, px[x]);
        auto out = relief::slopes(img, with(NormalConvention::OpenGL));
        REQUIRE_FALSE(out.has_error());
        auto s = pixels(out);
        for (int i = 0; i < 6; ++i)
            CHECK(s[i] == 0.0);
        CHECK(s[6] == 0.0);
        CHECK(s[7] != 0.0);  // a real tilt stays
    }
}

TEST_CASE("a float map stored in [0, 1] read as signed warns to use range=unsigned", "[ddm]")
{
    const auto g = kField.slopes();
    auto img = test::normal_image(g, kField.width, kField.height, Green::OpenGL, TypeDesc::FLOAT, 3, true);
    std::string warned;
    SlopeOptions o = with(NormalConvention::OpenGL);
    o.exec.on_message = [&](Severity s, const std::string& m) {
        if (s == Severity::Warning)
            warned += m;
    };
    REQUIRE_FALSE(relief::slopes(img, o).has_error());
    CHECK(warned.find("range=unsigned") != std::string::npos);
    warned.clear();
    o.normals.float_encoding = FloatEncoding::Unsigned;
    auto out = relief::slopes(img, o);
    REQUIRE_FALSE(out.has_error());
    CHECK(warned.empty());
    CHECK(max_diff(pixels(out), g) < 2e-5);
    // signed data does not warn: the same field, and a flat map (x = y = 0,
    // blue 1: every value in [0, 1])
    o.normals.float_encoding = FloatEncoding::Signed;
    REQUIRE_FALSE(
        relief::slopes(
            test::normal_image(g, kField.width, kField.height, Green::OpenGL, TypeDesc::FLOAT, 3, false), o)
            .has_error());
    std::vector<float> flat(3 * std::size_t(kField.width) * kField.height, 0.0f);
    for (std::size_t i = 2; i < flat.size(); i += 3)
        flat[i] = 1.0f;
    REQUIRE_FALSE(relief::slopes(test::image(kField.width, kField.height, 3, flat), o).has_error());
    // nor a map tilted along one axis: every value in [0, 1], but only x,
    // or only y, centred on 0.5
    for (int axis = 0; axis < 2; ++axis) {
        std::vector<float> tilted(flat.size(), 0.0f);
        for (std::size_t i = 0; i < tilted.size(); i += 3) {
            tilted[i + axis] = 0.5f;
            tilted[i + 2] = std::sqrt(0.75f);
        }
        REQUIRE_FALSE(relief::slopes(test::image(kField.width, kField.height, 3, tilted), o).has_error());
    }
    CHECK(warned.empty());
}

TEST_CASE("the normal map goes to the device in chunks: same slopes, same counts", "[ddm]")
{
    // A cap between the slopes' 8 bytes and the RGB input's 12 per texel
    // makes the upload come in chunks; bad and grazing texels land in both.
    const int w = kField.width, h = kField.height;  // 6144 texels
    auto normals = test::normal_image(kField.slopes(), w, h, Green::OpenGL, TypeDesc::FLOAT);
    std::vector<float> px = pixels(normals);
    px[3 * 10] = std::numeric_limits<float>::quiet_NaN();  // chunk 1
    px[3 * 6000 + 2] = 0.01f;                              // chunk 2: grazing
    const OIIO::ImageBuf damaged = test::image(w, h, 3, px);
    const SlopeOptions o = with(NormalConvention::OpenGL);
    const OIIO::ImageBuf a = slopes(damaged, o);
    ::setenv("RELIEF_DEVICE_MAX_ALLOC", "60000", 1);  // 6144 * 8 < 60000 < 6144 * 12
    const OIIO::ImageBuf b = slopes(damaged, o);
    ::unsetenv("RELIEF_DEVICE_MAX_ALLOC");
    REQUIRE_FALSE(b.has_error());
    CHECK(pixels(a) == pixels(b));
    CHECK(a.spec().get_int_attribute("relief:invalid_normals") == 1);
    CHECK(b.spec().get_int_attribute("relief:invalid_normals") == 1);
    CHECK(b.spec().get_int_attribute("relief:clamped_normals") >= 1);
    CHECK(a.spec().get_int_attribute("relief:clamped_normals") ==
          b.spec().get_int_attribute("relief:clamped_normals"));
}
