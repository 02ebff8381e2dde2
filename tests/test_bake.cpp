// Baking: the device gather against the golden model, exact zero-offset
// round trips, colour management, seams, and the command line's examples
// and refusals.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "bake_stage.h"
#include "colour.h"
#include "compute_context.h"
#include "reference/bake_reference.h"
#include "relief/bake.h"
#include "relief/errors.h"
#include "support/run_cli.h"

using namespace relief;
namespace fs = std::filesystem;
using relief::test::run_cli;

namespace {

const std::string kData = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01";

fs::path scratch(const std::string& name)
{
    fs::path d = fs::path(RELIEF_TEST_TMP) / "bake" / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

std::vector<float> random_field(std::size_t n, unsigned seed, float lo, float hi)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(lo, hi);
    std::vector<float> v(n);
    for (float& x : v)
        x = u(rng);
    return v;
}

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

} // namespace

TEST_CASE("bake: device gather equals the golden model", "[bake]")
{
    const int w = 37, h = 29, nch = 3;
    const auto src = random_field(std::size_t(w) * h * nch, 1, 0.0f, 1.0f);
    const auto off = random_field(2 * std::size_t(w) * h, 2, -0.1f, 0.1f);
    auto ctx = host::ComputeContext::acquire("auto");
    for (bool periodic : {true, false})
        for (bool bicubic : {false, true}) {
            std::vector<float> out(src.size());
            host::bake_gather(*ctx, src.data(), w, h, nch, off.data(), periodic,
                              bicubic ? host::BakeFilter::Bicubic : host::BakeFilter::Bilinear, out.data());
            const auto gold = reference::bake_gather(std::vector<double>(src.begin(), src.end()), w, h, nch,
                                                     std::vector<double>(off.begin(), off.end()), periodic, bicubic);
            double worst = 0.0;
            for (std::size_t i = 0; i < out.size(); ++i)
                worst = std::max(worst, std::abs(out[i] - gold[i]));
            INFO("periodic " << periodic << " bicubic " << bicubic);
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
    std::vector<float> src(std::size_t(w) * h * 3), off(2 * std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            for (int c = 0; c < 3; ++c)
                src[(std::size_t(y) * w + x) * 3 + c] = x < w / 2 ? 0.0f : 1.0f;
            off[2 * (std::size_t(y) * w + x)] = 0.5f / w;
        }
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
            const std::size_t from = std::size_t((y + sy) % h) * w + (x + sx) % w, to = std::size_t(y) * w + x;
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
    CHECK(geterror().find("offset map is") != std::string::npos);
    CHECK_FALSE(bake(out, image(w, h, 3, nrm), image(w, h, 1, std::vector<float>(w * h)), d));
    CHECK(geterror().find("channel") != std::string::npos);
    d.kind = BakeKind::Height;
    CHECK_FALSE(bake(out, image(w, h, 1, std::vector<float>(w * h)), image(w, h, 2, off), d));
    CHECK(geterror().find("displacement") != std::string::npos);
}

TEST_CASE("cli: correct and bake, the documented examples", "[cli][bake]")
{
    auto dir = scratch("examples");
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
    const std::string json = relief::test::slurp(dir / "report.json");
    for (const char* key : {"\"energy_before\"", "\"energy_after\"", "\"iterations\"", "\"anisotropy\"",
                            "\"area_ratio\"", "\"p95\"", "\"seconds\""})
        CHECK(json.find(key) != std::string::npos);

    // The second: a colour texture baked through the offsets, kept 8-bit.
    // (The metal set's normal map stands in for an albedo: 3 channels,
    // colorspace forced to sRGB, kind forced to colour.)
    r = run_cli("'" + normal + "' '" + height + "' --correct:scale=0.05:nodes=center -o '" +
                (dir / "off2.exr").string() + "' --bake:filter=bilinear:colorspace=sRGB:kind=color -o '" +
                (dir / "albedo_fixed.png").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    OIIO::ImageBuf baked((dir / "albedo_fixed.png").string());
    REQUIRE(baked.read());
    CHECK(baked.spec().format == OIIO::TypeDesc::UINT8);
    CHECK(baked.spec().width == 512);

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
    auto dir = scratch("bad");
    const std::string height = kData + "/height.png", normal = kData + "/normal.png";
    const std::string out = (dir / "o.exr").string();
    auto r = run_cli("'" + height + "' --correct:scale=0 -o '" + out + "'");
    CHECK(r.rc != 0);
    CHECK(r.err.find("scale") != std::string::npos);
    r = run_cli("'" + height + "' --correct -o '" + out + "'");  // no scale, not relief's own height
    CHECK(r.rc != 0);
    CHECK(r.err.find("scale") != std::string::npos);
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
    r = run_cli("'" + height + "' --correct:scale=0.05 --report '" + (dir / "r.json").string() + "' --correct:scale=0.1 -o '" + out + "'");
    CHECK(r.rc == 2);
    CHECK(fs::is_empty(dir));
}
