// SPDX-License-Identifier: Apache-2.0
// Rational directions and the fast ray kernel (docs/design.md §4.3): the reference
// kernel with rational directions against the golden model, and the fast
// kernel against the reference kernel for the same direction set.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstring>
#include <random>

#include "device/compute_context.h"
#include "rays/rays_stage.h"
#include "rays/rays_walk.h"
#include "reference/rays_reference.h"
#include "slopes/slope_stage.h"
#include "support/fields.h"
#include "support/images.h"

using namespace relief;

namespace {

// A map size and the ray settings the kernels under test share.
struct Case {
    int w, h;
    reference::RaySettings s;
};

// A run of the fast kernel or the reference one with `s`.
struct Run {
    reference::RaySettings s;
    bool fast = false;
    bool force_float = false;
    // Periodic: the FFT convolution, else chain windows. Clip: the FFT
    // where every ray stays in the image and chains in the band, else
    // chains everywhere.
    bool by_fft = true;
};

std::vector<float> run_rays(const std::vector<float>& g, int w, int h, const Run& r)
{
    auto ctx = host::ComputeContext::acquire("auto");
    auto slopes = host::upload_slopes(*ctx, g.data(), w, h);
    host::RayParams p;
    p.rays = r.s.rays;
    p.radius = r.s.radius;
    p.phase = r.s.phase;
    p.directions = host::DirectionSet::Rational;
    p.boundary = r.s.periodic ? host::RayBoundary::Periodic : host::RayBoundary::Clip;
    p.force_float = r.force_float;
    p.periodic_by_fft = r.by_fft;
    p.clip_by_fft = r.by_fft;
    std::vector<float> out(std::size_t(w) * h);
    if (r.fast)
        host::integrate_rays_fast(*ctx, slopes, p, out.data());
    else
        host::integrate_rays_reference(*ctx, slopes, p, out.data());
    return out;
}

// Smooth slopes plus non-integrable noise, in float.
std::vector<float> rough_float_slopes(int w, int h, unsigned seed, double noise_std = 0.3)
{
    const std::vector<double> g = test::rough_slopes(w, h, seed, noise_std);
    return std::vector<float>(g.begin(), g.end());
}

template <class A>
double stddev(const A& a)
{
    double s = 0, s2 = 0;
    for (auto v : a) {
        s += v;
        s2 += double(v) * v;
    }
    const double n = double(a.size());
    return std::sqrt(std::max(0.0, s2 / n - (s / n) * (s / n)));
}

bool all_finite(const std::vector<float>& v)
{
    for (float x : v)
        if (!std::isfinite(x))
            return false;
    return true;
}

}  // namespace

TEST_CASE("rational directions are primitive steps near the uniform angles", "[rays][fast]")
{
    // Steps of at most max(2, ceil(rays / 4)) texels along either axis.
    CHECK(host::rational_step_limit(1) == 2);
    CHECK(host::rational_step_limit(8) == 2);
    CHECK(host::rational_step_limit(9) == 3);
    CHECK(host::rational_step_limit(64) == 16);
    for (int rays : {1, 3, 4, 6, 8, 32, 64})
        for (double phase : {0.0, 0.25, 0.5, 0.75}) {
            INFO("rays " << rays << " phase " << phase);
            auto dirs = host::rational_directions(rays, phase);
            REQUIRE(int(dirs.size()) == rays);
            const int limit = host::rational_step_limit(rays);
            for (int j = 0; j < rays; ++j) {
                const auto& d = dirs[j];
                CHECK(std::gcd(d.a, d.b) == 1);
                CHECK(std::max(std::abs(d.a), std::abs(d.b)) <= limit);
                int a = 0, b = 0;
                reference::RaySettings s;
                s.rays = rays;
                s.phase = phase;
                reference::rational_step(j, s, a, b);
                CHECK(a == d.a);
                CHECK(b == d.b);
                // Within the angular gap of the step limit (Farey spacing).
                const double err =
                    std::abs(std::remainder(d.angle() - 2 * M_PI * (j + phase) / rays, 2 * M_PI));
                CHECK(err <= 1.0 / limit + 1e-9);
            }
        }
}

TEST_CASE("rational directions by continued fractions equal the exhaustive search", "[rays][fast]")
{
    // The search over every candidate step took 49 s for 2048 rays (it grows
    // as rays^3); the continued fractions must choose the very same steps.
    for (int rays : {1, 2, 3, 4, 5, 7, 8, 12, 16, 31, 32, 33, 64, 100, 128, 255, 256})
        for (double phase : {0.0, 0.25, 0.5, 0.9}) {
            INFO("rays " << rays << " phase " << phase);
            const auto fast = host::rational_directions(rays, phase);
            const auto slow = host::rational_directions_by_search(rays, phase);
            REQUIRE(fast.size() == slow.size());
            for (std::size_t j = 0; j < fast.size(); ++j) {
                INFO("direction " << j);
                CHECK(fast[j].a == slow[j].a);
                CHECK(fast[j].b == slow[j].b);
            }
        }
    // 4096 rays: milliseconds, not minutes.
    const auto t0 = std::chrono::steady_clock::now();
    const auto many = host::rational_directions(4096, 0.5);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    CHECK(many.size() == 4096);
    CHECK(seconds < 0.5);
    const int limit = host::rational_step_limit(4096);
    for (std::size_t j = 0; j < many.size(); ++j) {
        CHECK(std::gcd(many[j].a, many[j].b) == 1);
        const double err = std::abs(std::remainder(many[j].angle() - 2 * M_PI * (j + 0.5) / 4096, 2 * M_PI));
        CHECK(err <= 1.0 / limit + 1e-9);
    }
}

TEST_CASE("reference kernel with rational directions equals the golden model", "[rays][fast]")
{
    const Case cases[] = {
        {37, 29, 8, 5.0, 0.5, true},    {37, 29, 16, 23.7, 0.5, true},  // longer than the texture: wraps
        {37, 29, 12, 9.5, 0.25, false}, {24, 24, 8, 11.0, 0.0, true},   // (1, 1): through corners
        {17, 1, 6, 8.0, 0.5, false},
    };
    for (const Case& c : cases) {
        INFO(c.w << "x" << c.h << " rays=" << c.s.rays << " radius=" << c.s.radius
                 << (c.s.periodic ? " periodic" : " clip"));
        auto gf = rough_float_slopes(c.w, c.h, 11u + c.s.rays);
        std::vector<double> g(gf.begin(), gf.end());
        reference::RaySettings s = c.s;
        s.rational = true;
        auto ref = reference::rays(g, c.w, c.h, s);
        auto got = run_rays(gf, c.w, c.h, Run{c.s});
        double scale = 0;
        for (double v : ref)
            scale = std::max(scale, std::abs(v));
        CHECK(test::max_abs_diff(got, ref) <= 1e-5 * scale);
    }
}

namespace {

// The fast kernel against the reference kernel over the same rational
// directions, in every variant of `c`'s boundary: chain windows in fp64
// (where the device has it) and in float, re-anchored; the FFT convolution
// (periodic), or the FFT inside and chains in the border band (clip), and
// for clip that in float too.
void check_fast_against_reference(const Case& c)
{
    for (int variant : {0, 1, 2, 3}) {
        const bool force_float = variant == 1 || variant == 3, by_fft = variant >= 2;
        if (variant == 3 && c.s.periodic)
            continue;
        INFO(c.w << "x" << c.h << " rays=" << c.s.rays << " radius=" << c.s.radius
                 << (c.s.periodic ? " periodic" : " clip") << (by_fft ? " fft" : "")
                 << (force_float ? " float" : " fp64"));
        auto g = rough_float_slopes(c.w, c.h, 5u + c.s.rays);
        Run r{c.s};
        r.force_float = force_float;
        r.by_fft = by_fft;
        auto ref = run_rays(g, c.w, c.h, r);
        r.fast = true;
        auto got = run_rays(g, c.w, c.h, r);
        REQUIRE(all_finite(got));
        const double sd = stddev(ref);
        INFO("max diff " << test::max_abs_diff(got, ref) << ", std " << sd);
        CHECK(test::max_abs_diff(got, ref) <= 1e-4 * sd + 1e-7);
    }
}

}  // namespace

// At lengths of small primes; prime lengths (cycles of every direction as
// long as the axis, and VkFFT by Bluestein's algorithm, which costs 2x the
// cold kernel builds) are in the stress label.
TEST_CASE("fast kernel equals the reference kernel for the same directions", "[rays][fast]")
{
    check_fast_against_reference({35, 27, 8, 5.0, 0.5, true});
    check_fast_against_reference({35, 27, 12, 9.5, 0.25, false});  // clip: exits inside a period
}

TEST_CASE("the reference kernel accumulates in float when asked, as on a device without fp64", "[rays]")
{
    // force_float (and RELIEF_FP64=off) must reach the kernel: its sums in
    // float differ from fp64's in the last bits, within float's precision.
    const auto g = rough_float_slopes(35, 27, 9u);
    Run r{{8, 9.5, 0.5, true}};
    const auto fp64 = run_rays(g, 35, 27, r);
    r.force_float = true;
    const auto in_float = run_rays(g, 35, 27, r);
    INFO("max diff " << test::max_abs_diff(fp64, in_float) << ", std " << stddev(fp64));
    CHECK(test::max_abs_diff(fp64, in_float) <= 1e-4 * stddev(fp64));
    if (host::ComputeContext::acquire("auto")->fp64())
        CHECK(fp64 != in_float);
}

TEST_CASE("fast kernel on a one-texel map: no transform, a zero height, as the reference", "[rays][fast]")
{
    // (the stress case below sweeps thin and tiny maps; this one, whose
    // FFT would have a length of 1, is kept in the fast tier)
    check_fast_against_reference({1, 1, 8, 4.0, 0.5, true});
    check_fast_against_reference({1, 1, 8, 4.0, 0.5, false});
}

TEST_CASE("fast kernel equals the reference kernel at long radii, thin and tiny maps and FFT interiors",
          "[rays][fast][stress]")
{
    const Case cases[] = {
        {37, 29, 8, 5.0, 0.5, true},
        {37, 29, 12, 9.5, 0.25, false},  // clip: exits inside a period
        {37, 29, 16, 23.7, 0.5, true},   // K > cycle length for some directions
        {37, 29, 16, 60.0, 0.5, false},  // clip, rays longer than the texture
        {24, 24, 8, 11.0, 0.0, true},
        {23, 31, 7, 0.4, 0.0, true},   // shorter than half a texel: partial origin
        {23, 31, 7, 1.0, 0.0, false},  // exactly one period on the axes
        {1, 17, 6, 8.0, 0.5, true},
        {17, 1, 6, 8.0, 0.5, false},
        {1, 1, 8, 4.0, 0.5, true},
        {1, 1, 8, 4.0, 0.5, false},
        {64, 48, 32, 40.0, 0.5, true},
        {64, 48, 32, 40.0, 0.5, false},
        // Clip with an FFT interior: its rectangle comes from the walks'
        // offsets, which differ per side for odd J and phases other than 0.5.
        {96, 80, 16, 10.0, 0.25, false},
        {101, 77, 7, 13.0, 0.0, false},
        {160, 120, 32, 24.0, 0.5, false},
    };
    for (const Case& c : cases)
        check_fast_against_reference(c);
}

TEST_CASE("flat tiles are skipped and the result is bit-identical", "[rays][fast][skip][slow]")
{
    // An atlas: bumpy islands on an exactly flat background.
    const int w = 300, h = 220;
    auto g = rough_float_slopes(w, h, 99u, 0.2);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool island = (x > 20 && x < 90 && y > 30 && y < 80) || (x > 200 && y > 150);
            if (!island)
                g[2 * (std::size_t(y) * w + x)] = g[2 * (std::size_t(y) * w + x) + 1] = 0.0f;
        }
    auto ctx = host::ComputeContext::acquire("auto");
    auto slopes = host::upload_slopes(*ctx, g.data(), w, h);
    for (bool fast : {true, false})
        for (bool periodic : {true, false}) {
            INFO((fast ? "fast" : "reference") << (periodic ? " periodic" : " clip"));
            host::RayParams p;
            p.rays = 16;
            p.radius = 24;
            p.directions = host::DirectionSet::Rational;
            p.boundary = periodic ? host::RayBoundary::Periodic : host::RayBoundary::Clip;
            p.periodic_by_fft = false;  // the FFT path's cost has nothing to skip
            std::vector<float> out[2];
            host::RayReport report[2];
            for (int skip : {0, 1}) {
                p.skip_flat = skip;
                out[skip].resize(std::size_t(w) * h);
                if (fast)
                    host::integrate_rays_fast(*ctx, slopes, p, out[skip].data(), {}, &report[skip]);
                else
                    host::integrate_rays_reference(*ctx, slopes, p, out[skip].data(), {}, &report[skip]);
            }
            CHECK(report[0].skipped == 0);
            CHECK(report[1].skipped > report[1].tiles / 4);
            CHECK(std::memcmp(out[0].data(), out[1].data(), out[0].size() * sizeof(float)) == 0);
        }
}
