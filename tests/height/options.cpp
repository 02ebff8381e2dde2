// SPDX-License-Identifier: Apache-2.0
// The height options reach their integrators: for every option, the API's
// result equals the host call made with the same parameters (bit for bit:
// same device, same kernels), and the option changes the result, so an
// option that is ignored, swapped or given the wrong default fails.
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

// Reference rays, periodic: 6 of radius 9 at phase 0.125.
void reference_rays_periodic(HeightOptions& o)
{
    o.method = HeightMethod::Rays;
    o.boundary = Boundary::Periodic;
    o.impl = RayImpl::Reference;
    o.rays = 6;
    o.radius = 9;
    o.phase = 0.125f;
}

// Fast rays, clipped: 12 of radius 7 at phase 0.25.
void clip_rays(HeightOptions& o)
{
    o.method = HeightMethod::Rays;
    o.boundary = Boundary::Free;
    o.rays = 12;
    o.radius = 7;
    o.phase = 0.25f;
}

}  // namespace

TEST_CASE("options: every height option reaches its integrator", "[options][height]")
{
    const auto g = tiling_slopes(kW, kH, 3);
    const ImageBuf normals = test::normal_image(g, kW, kH, test::Green::OpenGL, TypeDesc::FLOAT);
    const auto slopes = api_slopes(normals);
    const int w = kW, h = kH;
    using DS = host::DirectionSet;
    const HeightCase cases[] = {
        {"poisson periodic",
         [](HeightOptions& o) {
             o.method = HeightMethod::Poisson;
             o.boundary = Boundary::Periodic;
         },
         [&](const auto& s) { return host_poisson(s, w, h, poisson(true)); }},
        {"poisson free",
         [](HeightOptions& o) {
             o.method = HeightMethod::Poisson;
             o.boundary = Boundary::Free;
         },
         [&](const auto& s) { return host_poisson(s, w, h, poisson(false)); }},
        {"auto method is poisson", [](HeightOptions& o) { o.boundary = Boundary::Free; },
         [&](const auto& s) { return host_poisson(s, w, h, poisson(false)); }},
        {"poisson periodic highpass 12",
         [](HeightOptions& o) {
             o.method = HeightMethod::Poisson;
             o.boundary = Boundary::Periodic;
             o.highpass = 12;
         },
         [&](const auto& s) { return host_poisson(s, w, h, poisson(true, 12)); }},
        {"poisson free highpass 9",
         [](HeightOptions& o) {
             o.boundary = Boundary::Free;
             o.highpass = 9;
         },
         [&](const auto& s) { return host_poisson(s, w, h, poisson(false, 9)); }},
        {"poisson periodic along x, free along y",
         [](HeightOptions& o) {
             o.boundary = {Boundary::Periodic, Boundary::Free};
         },
         [&](const auto& s) { return host_poisson(s, w, h, poisson_axes(true, false)); }},
        {"poisson free along x, periodic along y, highpass 10",
         [](HeightOptions& o) {
             o.boundary = {Boundary::Free, Boundary::Periodic};
             o.highpass = 10;
         },
         [&](const auto& s) { return host_poisson(s, w, h, poisson_axes(false, true, 10)); }},
        {"rays fast periodic (defaults)",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.boundary = Boundary::Periodic;
         },
         [&](const auto& s) { return host_rays(s, w, h, rays(32, 64, 0.5, true), true); }},
        {"rays fast periodic rays 8 radius 10",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.boundary = Boundary::Periodic;
             o.rays = 8;
             o.radius = 10;
         },
         [&](const auto& s) { return host_rays(s, w, h, rays(8, 10, 0.5, true), true); }},
        {"rays fast clip rays 12 radius 7 phase 0.25", clip_rays,
         [&](const auto& s) { return host_rays(s, w, h, rays(12, 7, 0.25, false), true); }},
        {"rays fast clip skip off",
         [](HeightOptions& o) {
             clip_rays(o);
             o.skip_flat = false;
         },
         [&](const auto& s) {
             auto p = rays(12, 7, 0.25, false);
             p.skip_flat = false;
             return host_rays(s, w, h, p, true);
         }},
        {"rays reference periodic exact directions phase 0.125",
         [](HeightOptions& o) {
             reference_rays_periodic(o);
             o.directions = RayDirections::Exact;
         },
         [&](const auto& s) { return host_rays(s, w, h, rays(6, 9, 0.125, true, DS::Exact), false); }},
        {"rays reference periodic rational phase 0.125", reference_rays_periodic,
         [&](const auto& s) { return host_rays(s, w, h, rays(6, 9, 0.125, true, DS::Rational), false); }},
        {"rays reference clip rational",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.boundary = Boundary::Free;
             o.impl = RayImpl::Reference;
             o.rays = 10;
             o.radius = 8;
         },
         [&](const auto& s) { return host_rays(s, w, h, rays(10, 8, 0.5, false, DS::Rational), false); }},
    };
    std::vector<std::vector<float>> results;
    for (const HeightCase& c : cases) {
        INFO(c.name);
        HeightOptions o;
        c.api(o);
        const auto got = api_height(normals, o);
        const auto want = c.host(slopes);
        REQUIRE(got.size() == want.size());
        CHECK(max_abs_diff(got, want) == 0.0);
        results.push_back(got);
    }
    // Each option changes the result: none of them could be ignored unseen.
    for (std::size_t a = 0; a < results.size(); ++a)
        for (std::size_t b = a + 1; b < results.size(); ++b) {
            const auto pair = [&](const std::string& x, const std::string& y) {
                return cases[a].name == x && cases[b].name == y;
            };
            const bool same_by_design =  // auto = poisson; skip
                pair("poisson free", "auto method is poisson") ||
                pair("rays fast clip rays 12 radius 7 phase 0.25", "rays fast clip skip off");
            INFO(cases[a].name << " vs " << cases[b].name);
            if (same_by_design)
                CHECK(results[a] == results[b]);
            else
                CHECK(max_abs_diff(results[a], results[b]) > 1e-4);
        }
}

TEST_CASE("options: clipped rays count their chains' buffers in the memory they are refused for",
          "[options][rays][memory]")
{
    // Periodic rays are one FFT convolution (four grids, about 16 bytes a
    // texel); clipped rays walk chains, whose sums, tails, accumulators and
    // output hold 36 bytes a texel beside the slopes. On a device whose
    // buffers are host memory both count in RELIEF_MEMORY_LIMIT. Measured:
    // 16 bytes a texel periodic, 52 clipped.
    const bool unified = host::device_memory(*host::ComputeContext::acquire("auto")).host_unified;
    if (!unified) {
        WARN("the device's buffers are not host memory: RELIEF_MEMORY_LIMIT does not hold them");
        return;
    }
    const int n = 256;
    const ImageBuf normals = memory_test_normals(n);
    HeightOptions periodic;
    periodic.method = HeightMethod::Rays;
    periodic.boundary = Boundary::Periodic;
    periodic.normals.convention = NormalConvention::OpenGL;
    HeightOptions clipped = periodic;
    clipped.boundary = Boundary::Free;
    const double texels = double(n) * n, fft = smallest_memory_limit(normals, periodic),
                 chains = smallest_memory_limit(normals, clipped);
    std::printf("memory for %dx%d rays: %.1f bytes a texel periodic, %.1f clipped\n", n, n, fft / texels,
                chains / texels);
    CHECK(chains - fft >= (36.0 - 17.0) * texels - 2048.0);  // (bisected to 1 KiB)
    // The estimate itself, as measured: a change to what either counts
    // (a buffer more or less) moves it by 4 bytes a texel or more.
    CHECK(std::abs(fft / texels - 16.1) <= 1.0);
    CHECK(std::abs(chains / texels - 52.0) <= 1.0);
}

TEST_CASE("options: skip=on skips flat tiles and says so, skip=off runs them all", "[options][height]")
{
    // A bump in one corner of a flat 128^2 map: most 32^2 tiles see only
    // zero slopes within the radius.
    const int n = 128;
    std::vector<double> g(2 * std::size_t(n) * n, 0.0);
    for (int y = 0; y < 24; ++y)
        for (int x = 0; x < 24; ++x) {
            g[2 * (std::size_t(y) * n + x)] = 0.3 * std::sin(0.5 * x);
            g[2 * (std::size_t(y) * n + x) + 1] = 0.2 * std::cos(0.4 * y);
        }
    const ImageBuf normals = test::normal_image(g, n, n, test::Green::OpenGL, TypeDesc::FLOAT);
    HeightOptions o;
    o.method = HeightMethod::Rays;
    o.boundary = Boundary::Free;
    o.rays = 8;
    o.radius = 8;
    std::string on, off;
    const auto a = api_height(normals, o, &on);
    o.skip_flat = false;
    const auto b = api_height(normals, o, &off);
    CHECK(a == b);
    INFO(on);
    CHECK(on.find("rays: skipped 12 of 16 tiles") != std::string::npos);
    CHECK(off.find("skipped") == std::string::npos);
}

TEST_CASE("options: a height over an ROI is that region's size, placed at its origin", "[options][height]")
{
    std::vector<float> up(64 * 48 * 3, 0.0f);
    for (std::size_t i = 2; i < up.size(); i += 3)
        up[i] = 1.0f;
    const OIIO::ImageBuf normals = test::image(64, 48, 3, up);
    HeightOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    for (const HeightMethod method : {HeightMethod::Poisson, HeightMethod::Rays}) {
        o.method = method;
        const OIIO::ImageBuf h = relief::height(normals, o, OIIO::ROI(10, 40, 5, 25));
        REQUIRE_FALSE(h.has_error());
        CHECK(h.spec().width == 30);
        CHECK(h.spec().height == 20);
        CHECK(h.spec().x == 10);
        CHECK(h.spec().y == 5);
    }
}
