// Numerical stability under stress (issue 3 §4): awkward sizes and fields,
// long chains, a very large map, and thread-count determinism. Every output
// must be finite and within the stated bounds.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "compute_context.h"
#include "ray_stage.h"
#include "reference/rays_reference.h"
#include "relief/relief.h"
#include "slope_stage.h"
#include "support/fields.h"
#include "support/run_cli.h"

using namespace relief;
namespace fs = std::filesystem;

namespace {

struct Method {
    const char* name;
    HeightOptions options;
};

std::vector<Method> methods()
{
    std::vector<Method> m;
    for (auto b : {Boundary::Periodic, Boundary::Free}) {
        HeightOptions p;
        p.method = HeightMethod::Poisson;
        p.boundary = b;
        m.push_back({b == Boundary::Periodic ? "poisson periodic" : "poisson free", p});
        HeightOptions r;
        r.method = HeightMethod::Rays;
        r.rays = 8;
        r.radius = 12;
        r.boundary = b;
        m.push_back({b == Boundary::Periodic ? "rays periodic" : "rays clip", r});
    }
    return m;
}

// Stated bounds (texel units): a ray's relative heights are at most
// max|g| * R and the mean removal at most doubles that; least squares heights
// stay within max|g| * (W + H).
double bound(const HeightOptions& o, double max_slope, int w, int h)
{
    return o.method == HeightMethod::Rays ? 2.0 * max_slope * o.radius
                                          : max_slope * (w + h);
}

void check_output(const OIIO::ImageBuf& out, const HeightOptions& o, double max_slope, int w, int h)
{
    REQUIRE_FALSE(out.has_error());
    std::vector<float> v(std::size_t(w) * h);
    REQUIRE(out.get_pixels(out.roi(), OIIO::TypeDesc::FLOAT, v.data()));
    float worst = 0;
    std::size_t bad = 0;
    for (float x : v) {
        bad += !std::isfinite(x);
        worst = std::max(worst, std::abs(x));
    }
    CHECK(bad == 0);
    CHECK(worst <= bound(o, max_slope, w, h) + 1e-6);
}

} // namespace

TEST_CASE("stress: awkward sizes and fields give finite, bounded heights", "[stress]")
{
    struct Size {
        int w, h;
    };
    const Size sizes[] = {{1, 1}, {1, 9}, {9, 1}, {2, 2}, {1, 257}, {257, 1}, {31, 17}, {127, 61}};
    std::mt19937 rng(42);
    for (const Size& s : sizes) {
        const std::size_t n = std::size_t(s.w) * s.h;
        // grazing: normals within a hair of the horizon (the clamp engages);
        // noise: random, non-integrable slopes; tilt: a constant slope.
        struct Field {
            const char* name;
            std::vector<double> g;
        };
        std::vector<Field> fields(3);
        fields[0].name = "grazing";
        fields[1].name = "noise";
        fields[2].name = "tilt";
        std::normal_distribution<double> noise(0.0, 1.0);
        for (std::size_t i = 0; i < n; ++i) {
            const double a = 2 * M_PI * (i % 7) / 7.0;
            fields[0].g.insert(fields[0].g.end(), {1e6 * std::cos(a), 1e6 * std::sin(a)});
            fields[1].g.insert(fields[1].g.end(), {noise(rng), noise(rng)});
            fields[2].g.insert(fields[2].g.end(), {0.8, -0.3});
        }
        for (const Field& f : fields) {
            auto img = test::normal_image(f.g, s.w, s.h, test::Green::OpenGL, OIIO::TypeDesc::FLOAT);
            for (const Method& m : methods()) {
                INFO(s.w << "x" << s.h << " " << f.name << " " << m.name);
                HeightOptions o = m.options;
                o.normals.convention = NormalConvention::OpenGL;
                auto out = relief::height(img, o);
                // The clamp limits slopes to tan(85 deg) = 11.43.
                const double max_slope = std::tan(85.0 * M_PI / 180.0) + 1e-3;
                check_output(out, o, max_slope, s.w, s.h);
                if (std::string(f.name) == "tilt" && o.boundary == Boundary::Periodic) {
                    // A constant tilt does not tile: periodic integration has
                    // nothing to keep but rounding.
                    float v = 0;
                    out.getpixel(s.w / 2, s.h / 2, &v, 1);
                    CHECK(std::abs(v) < 1e-3f);
                }
            }
        }
    }
}

TEST_CASE("stress: 16K-long chains, fast kernel against the golden model in double", "[stress][fast]")
{
    // 16384 x 8: the chains along x are 16K texels long.
    const int w = 16384, h = 8;
    test::PeriodicField f{w, h, {{3, 1, 40.0, 0.3}, {17, 0, 5.0, 1.1}, {250, 3, 0.5, 2.0}}};
    auto g = f.slopes();
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 0.05);
    for (double& v : g)
        v += noise(rng);
    std::vector<float> gf(g.begin(), g.end());
    auto ctx = host::ComputeContext::acquire("auto");
    auto slopes = host::upload_slopes(*ctx, gf.data(), w, h);
    for (bool periodic : {true, false}) {
        reference::RaySettings s{4, 256.0, 0.0, periodic};
        s.rational = true;
        auto ref = reference::rays(g, w, h, s);
        double mean = 0, var = 0;
        for (double v : ref)
            mean += v;
        mean /= double(ref.size());
        for (double v : ref)
            var += (v - mean) * (v - mean);
        const double sd = std::sqrt(var / double(ref.size()));
        for (int variant : {0, 1, 2}) {
            // 0: chains in fp64, 1: chains in float (re-anchored), 2: FFT.
            const bool force_float = variant == 1;
            if ((variant == 0 && !ctx->device().has_fp64) || (variant == 2 && !periodic))
                continue;
            host::RayParams p;
            p.rays = 4;
            p.radius = 256;
            p.phase = 0.0;
            p.directions = host::DirectionSet::Rational;
            p.boundary = periodic ? host::RayBoundary::Periodic : host::RayBoundary::Clip;
            p.force_float = force_float;
            p.periodic_by_fft = variant == 2;
            std::vector<float> got(std::size_t(w) * h);
            host::integrate_rays_fast(*ctx, slopes, p, got.data());
            double worst = 0;
            std::size_t bad = 0;
            for (std::size_t i = 0; i < got.size(); ++i) {
                bad += !std::isfinite(got[i]);
                worst = std::max(worst, std::abs(got[i] - ref[i]));
            }
            CHECK(bad == 0);
            INFO((periodic ? "periodic" : "clip")
                 << (variant == 2 ? ", fft" : force_float ? ", float re-anchored" : ", fp64")
                                                  << ": max diff " << worst << ", std " << sd);
            CHECK(worst <= 1e-4 * sd);
        }
    }
}

TEST_CASE("stress: an 8192x8192 map integrates in bounded memory", "[stress][large]")
{
    const int n = 8192;
    OIIO::ImageBuf img(OIIO::ImageSpec(n, n, 3, OIIO::TypeDesc::UINT8));
    {
        std::vector<unsigned char> px(std::size_t(n) * n * 3);
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                unsigned char* p = &px[3 * (std::size_t(y) * n + x)];
                p[0] = (unsigned char)(128 + 60 * std::sin(x * 0.01));
                p[1] = (unsigned char)(128 + 60 * std::cos(y * 0.013));
                p[2] = 220;
            }
        img.set_pixels(img.roi(), OIIO::TypeDesc::UINT8, px.data());
    }
    for (const Method& m : methods()) {
        if (m.options.method == HeightMethod::Rays && m.options.boundary == Boundary::Free)
            continue;  // one ray run is enough at this size
        INFO(m.name);
        HeightOptions o = m.options;
        o.normals.convention = NormalConvention::OpenGL;
        o.rays = 4;
        o.radius = 8;
        auto out = relief::height(img, o);
        check_output(out, o, std::tan(85.0 * M_PI / 180.0), n, n);
    }
}

TEST_CASE("stress: results are identical whatever POCL_MAX_PTHREAD_COUNT is", "[stress][cli]")
{
    const fs::path dir = fs::path(RELIEF_TEST_TMP) / "threads";
    fs::create_directories(dir);
    const std::string in = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
    for (const char* mods : {"method=poisson:boundary=free", "method=poisson:boundary=periodic",
                             "method=rays:rays=16:radius=24:boundary=clip",
                             "method=rays:rays=16:radius=24:boundary=periodic"}) {
        std::string bits[2];
        for (int t : {1, 2}) {
            const fs::path out = dir / ("h" + std::to_string(t) + ".exr");
            auto r = test::run_cli("'" + in + "' --height:" + mods + " -o '" + out.string() + "'",
                                   "POCL_MAX_PTHREAD_COUNT=" + std::to_string(t));
            INFO(mods << ": " << r.err);
            REQUIRE(r.rc == 0);
            OIIO::ImageBuf img(out.string());
            REQUIRE(img.read(0, 0, true, OIIO::TypeDesc::FLOAT));
            std::vector<float> v(std::size_t(img.spec().width) * img.spec().height);
            img.get_pixels(img.roi(), OIIO::TypeDesc::FLOAT, v.data());
            bits[t - 1].assign(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
        }
        INFO(mods);
        CHECK(bits[0] == bits[1]);
    }
}
