// SPDX-License-Identifier: Apache-2.0
// Numerical stability under stress (issue 3, part 4): awkward sizes and fields,
// long chains, a very large map, and thread-count determinism. Every output
// must be finite and within the stated bounds.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "device/compute_context.h"
#include "rays/rays_stage.h"
#include "reference/ddm_reference.h"
#include "reference/poisson_reference.h"
#include "reference/rays_reference.h"
#include "relief/relief.h"
#include "slopes/slope_stage.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/run_cli.h"

using namespace relief;
namespace fs = std::filesystem;

#ifndef RELIEF_SANITIZE
#define RELIEF_SANITIZE 0
#endif

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
    return o.method == HeightMethod::Rays ? 2.0 * max_slope * o.radius : max_slope * (w + h);
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

// The process's peak resident set size since it started or since the last
// reset_peak_rss() (Linux's VmHWM; getrusage's maxrss is not reset).
double peak_rss_bytes()
{
    std::ifstream status("/proc/self/status");
    for (std::string line; std::getline(status, line);)
        if (line.rfind("VmHWM:", 0) == 0)
            return std::stod(line.substr(6)) * 1024.0;  // in kB
    FAIL("no VmHWM in /proc/self/status");
    return 0.0;
}

// Starts the peak again from the present resident size (Linux 4.0 and
// later: "5" into clear_refs).
void reset_peak_rss()
{
    std::ofstream clear("/proc/self/clear_refs");
    clear << "5" << std::flush;
    REQUIRE(clear.good());
}

// Four rays of `radius` texels: the long chains the stress cases walk.
host::RayParams few_long_rays(double radius, double phase, host::DirectionSet directions, bool force_float)
{
    host::RayParams p;
    p.rays = 4;
    p.radius = radius;
    p.phase = phase;
    p.directions = directions;
    p.force_float = force_float;
    return p;
}

}  // namespace

TEST_CASE("stress: awkward sizes and fields equal the golden models, finite and bounded", "[stress]")
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
        const double tilt_x = 0.8, tilt_y = -0.3;
        for (std::size_t i = 0; i < n; ++i) {
            const double a = 2 * M_PI * (i % 7) / 7.0;
            fields[0].g.insert(fields[0].g.end(), {1e6 * std::cos(a), 1e6 * std::sin(a)});
            fields[1].g.insert(fields[1].g.end(), {noise(rng), noise(rng)});
            fields[2].g.insert(fields[2].g.end(), {tilt_x, tilt_y});
        }
        for (const Field& f : fields) {
            auto img = test::normal_image(f.g, s.w, s.h, test::Green::OpenGL, OIIO::TypeDesc::FLOAT);
            // The golden slopes of the stored normals (clamped at 85 degrees).
            const auto stored = test::pixels(img);
            const auto golden_slopes = reference::ddm(stored, 3, 1.0, 0.0, -1.0, 85.0).slopes;
            for (const Method& m : methods()) {
                INFO(s.w << "x" << s.h << " " << f.name << " " << m.name);
                HeightOptions o = m.options;
                o.normals.convention = NormalConvention::OpenGL;
                auto out = relief::height(img, o);
                // The clamp limits slopes to tan(85 deg) = 11.43.
                const double max_slope = std::tan(85.0 * M_PI / 180.0) + 1e-3;
                check_output(out, o, max_slope, s.w, s.h);
                const bool periodic = o.boundary == Boundary::Periodic;
                std::vector<double> golden;
                if (o.method == HeightMethod::Poisson) {
                    reference::PoissonSettings ps;
                    ps.periodic_x = ps.periodic_y = periodic;
                    golden = reference::poisson(golden_slopes, s.w, s.h, ps);
                } else {
                    reference::RaySettings rs{o.rays, o.radius, o.phase, periodic};
                    rs.rational = true;
                    golden = reference::rays(golden_slopes, s.w, s.h, rs);
                }
                const auto got = test::pixels(out);
                INFO("max |device - golden| " << test::max_abs_diff(got, golden) << ", max |golden| "
                                              << test::max_abs(golden));
                CHECK(test::max_abs_diff(got, golden) <= 1e-4 * test::max_abs(golden) + 1e-5);
                if (std::string(f.name) == "tilt" && periodic) {
                    // A constant tilt does not tile: periodic integration has
                    // nothing to keep but rounding.
                    CHECK(test::max_abs(got) < 1e-3);
                }
                if (std::string(f.name) == "tilt" && !periodic && o.method == HeightMethod::Poisson) {
                    // The plane, but for the free boundary's zero normal slope
                    // at the edges: measured at most 0.16 |g| at an edge
                    // texel, decaying inwards (0.015 |g| 8 texels in).
                    double mean = 0.0;
                    std::vector<double> plane(got.size());
                    for (int y = 0; y < s.h; ++y)
                        for (int x = 0; x < s.w; ++x)
                            mean += plane[std::size_t(y) * s.w + x] = tilt_x * x + tilt_y * y;
                    mean /= double(plane.size());
                    for (double& v : plane)
                        v -= mean;
                    CHECK(test::max_abs_diff(got, plane) <= 0.2 * std::hypot(tilt_x, tilt_y));
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
        const double sd = test::rms(ref);
        for (int variant : {0, 1, 2}) {
            // 0: chains in fp64, 1: chains in float (re-anchored), 2: FFT.
            const bool force_float = variant == 1;
            if ((variant == 0 && !ctx->fp64()) || (variant == 2 && !periodic))
                continue;
            host::RayParams p = few_long_rays(256, 0.0, host::DirectionSet::Rational, force_float);
            p.boundary = periodic ? host::RayBoundary::Periodic : host::RayBoundary::Clip;
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
            INFO((periodic ? "periodic" : "clip") << (variant == 2  ? ", fft"
                                                      : force_float ? ", float re-anchored"
                                                                    : ", fp64")
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
    // Peak resident memory per texel beyond what the process holds before
    // the measured runs (the input image among it), in the order of growing
    // need, so that each bound is the method's own peak. Measured here: 16.0
    // bytes per texel for each: the slopes (8) beside the transform's two
    // grids (8), freed before the plans' buffers and the result are made.
    // Before the stages took the slopes over: 18, 21 and 53-61 (then counted
    // from a peak that held a copy of the input's pixels, about 2 bytes a
    // texel lower).
    //
    // Each method runs once before the measured runs: with cold kernel
    // caches LLVM compiles VkFFT's kernels for this size inside the solve,
    // and its heap (about 170 MB, whatever the map's size) took the peaks so
    // counted from 14.3-14.4 to 16.7-17.1 bytes a texel, over the bound on
    // a fresh clone.
    const double texels = double(n) * n;
    struct Bounded {
        const char* name;
        HeightMethod method;
        Boundary boundary;
        double bytes_per_texel;
    };
    const Bounded all[] = {{"poisson periodic", HeightMethod::Poisson, Boundary::Periodic, 17.0},
                           {"poisson free", HeightMethod::Poisson, Boundary::Free, 17.0},
                           {"rays periodic", HeightMethod::Rays, Boundary::Periodic, 17.0}};
    const auto options = [](const Bounded& b) {
        HeightOptions o;
        o.method = b.method;
        o.boundary = b.boundary;
        o.normals.convention = NormalConvention::OpenGL;
        o.rays = 4;
        o.radius = 8;
        return o;
    };
    for (const Bounded& b : all)
        REQUIRE_FALSE(relief::height(img, options(b)).has_error());
    reset_peak_rss();
    const double before = peak_rss_bytes();
    for (const Bounded& b : all) {
        INFO(b.name);
        const HeightOptions o = options(b);
        auto out = relief::height(img, o);
        check_output(out, o, std::tan(85.0 * M_PI / 180.0), n, n);
        const double per_texel = (peak_rss_bytes() - before) / texels;
        std::printf("stress 8192^2 %s: peak RSS %.1f bytes per texel above the input\n", b.name, per_texel);
        if (!RELIEF_SANITIZE)  // the sanitizers' shadow memory and quarantine are theirs
            CHECK(per_texel < b.bytes_per_texel);
    }
}

TEST_CASE("stress: results are identical whatever POCL_MAX_PTHREAD_COUNT is", "[stress][cli]")
{
    const fs::path dir = fs::path(RELIEF_TEST_TMP) / "threads";
    fs::create_directories(dir);
    const std::string data = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/";
    const std::string normal = "'" + data + "normal.png' ", height = "'" + data + "height.png' ";
    // A mask that excludes a disc and weighs the rest by position.
    const int n = 512;
    std::vector<float> m(std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            m[std::size_t(y) * n + x] =
                std::hypot(x - 200.0, y - 300.0) < 60.0 ? 0.0f : 0.3f + 0.7f * float(x) / float(n);
    const std::string mask = (dir / "mask.exr").string();
    REQUIRE(test::image(n, n, 1, m).write(mask));
    for (const std::string& args :
         {normal + "--height:method=poisson:boundary=free",
          normal + "--height:method=poisson:boundary=periodic",
          normal + "--height:rays=16:radius=24:boundary=clip",
          normal + "--height:rays=16:radius=24:boundary=periodic",
          normal + "--height:boundary=free:mask=" + mask, normal + "--height:boundary=periodic:mask=" + mask,
          height + "--correct:scale=0.05:iterations=4",
          height + "--correct:scale=0.05:nodes=center:boundary=fixed:levels=1:iterations=6",
          normal + height + "--correct:scale=0.05:iterations=3 --bake:kind=color:filter=bicubic"}) {
        std::string bits[2];
        for (int t : {1, 3}) {
            const fs::path out = dir / ("h" + std::to_string(t) + ".exr");
            auto r = test::run_cli(args + " -o '" + out.string() + "'",
                                   "POCL_MAX_PTHREAD_COUNT=" + std::to_string(t));
            INFO(args << ": " << r.err);
            REQUIRE(r.rc == 0);
            const auto v = test::file_pixels(out);
            REQUIRE(v.size() >= std::size_t(n) * n);
            bits[t == 1 ? 0 : 1].assign(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
        }
        INFO(args);
        CHECK(bits[0] == bits[1]);
    }
}

TEST_CASE("stress: 65536-texel rays, reference kernel against the golden model in double", "[stress][rays]")
{
    // Plain float sums along a ray this long were off by 2e-3 of max|h|.
    const int w = 8, h = 6;
    test::PeriodicField f{w, h, {{1, 1, 3.0, 0.3}, {2, -1, 1.0, 1.1}}};
    const auto g = f.slopes();
    std::vector<float> gf(g.begin(), g.end());
    auto ctx = host::ComputeContext::acquire("auto");
    auto slopes = host::upload_slopes(*ctx, gf.data(), w, h);
    reference::RaySettings s{4, 65536.0, 0.5, true};
    const auto ref = reference::rays(g, w, h, s);
    double largest = 0;
    for (double v : ref)
        largest = std::max(largest, std::abs(v));
    REQUIRE(largest > 0.1);
    for (bool force_float : {false, true}) {
        if (!force_float && !ctx->fp64())
            continue;
        const host::RayParams p = few_long_rays(65536.0, 0.5, host::DirectionSet::Exact, force_float);
        std::vector<float> got(std::size_t(w) * h);
        host::integrate_rays_reference(*ctx, slopes, p, got.data());
        double worst = 0;
        for (std::size_t i = 0; i < got.size(); ++i)
            worst = std::isfinite(got[i]) ? std::max(worst, std::abs(got[i] - ref[i])) : INFINITY;
        INFO((force_float ? "float, compensated" : "fp64")
             << ": max diff " << worst << ", max |h| " << largest);
        CHECK(worst <= 1e-5 * largest);
    }
}
