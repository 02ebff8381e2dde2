// SPDX-License-Identifier: Apache-2.0
// Radial ray integration: the reference kernel against the C++ golden model
// and against analytic truth (h - mean over the disk of radius R).
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "device/compute_context.h"
#include "errors.h"
#include "rays/rays_stage.h"
#include "reference/rays_reference.h"
#include "reference/zero_mean.h"
#include "relief/relief.h"
#include "slopes/slope_stage.h"
#include "support/fields.h"

using namespace relief;

namespace {

std::vector<float> kernel_rays(const std::vector<double>& g, int w, int h, int rays, double radius,
                               double phase, bool periodic)
{
    auto ctx = host::ComputeContext::acquire("auto");
    std::vector<float> gf(g.begin(), g.end());
    auto slopes = host::upload_slopes(*ctx, gf.data(), w, h);
    host::RayParams p;
    p.rays = rays;
    p.radius = radius;
    p.phase = phase;
    p.boundary = periodic ? host::RayBoundary::Periodic : host::RayBoundary::Clip;
    std::vector<float> out(std::size_t(w) * h);
    host::integrate_rays_reference(*ctx, slopes, p, out.data());
    return out;
}

using test::rough_slopes;

double max_abs(const std::vector<double>& v)
{
    double m = 0;
    for (double x : v)
        m = std::max(m, std::abs(x));
    return m;
}

}  // namespace

TEST_CASE("reference kernel equals the C++ golden model", "[rays]")
{
    struct Case {
        int w, h, rays;
        double radius, phase;
        bool periodic;
    };
    const Case cases[] = {
        {37, 29, 8, 5.0, 0.5, true},
        {37, 29, 16, 50.0, 0.5, true},   // rays longer than the texture wrap around
        {37, 29, 12, 9.5, 0.25, false},  // clip: edges and corners use partial circles
        {23, 31, 7, 20.0, 0.0, false},   // phase 0: axis-aligned rays
        {24, 24, 8, 11.0, 0.0, true},    // phase 0, J = 8: exact diagonals through corners
        {1, 17, 6, 8.0, 0.5, true},      // one column
        {17, 1, 6, 8.0, 0.5, false},     // one row
    };
    for (const Case& c : cases) {
        INFO(c.w << "x" << c.h << " rays=" << c.rays << " radius=" << c.radius << " phase=" << c.phase
                 << (c.periodic ? " periodic" : " clip"));
        auto g = rough_slopes(c.w, c.h, 7u + c.rays);
        auto ref = reference::rays(g, c.w, c.h, {c.rays, c.radius, c.phase, c.periodic});
        auto got = kernel_rays(g, c.w, c.h, c.rays, c.radius, c.phase, c.periodic);
        double worst = 0;
        for (std::size_t i = 0; i < ref.size(); ++i) {
            REQUIRE(std::isfinite(got[i]));
            worst = std::max(worst, std::abs(got[i] - ref[i]));
        }
        CHECK(worst <= 1e-5 * max_abs(ref));
    }
}

TEST_CASE("on smooth periodic fields the result is h - mean_disk_R(h)", "[rays]")
{
    const test::PeriodicField f{256, 256, {{1, 0, 4.0, 0.2}, {1, 2, 2.0, 1.0}, {-3, 1, 1.0, 2.5}}};
    const auto g = f.slopes();
    for (double radius : {32.0, 64.0}) {
        auto got = kernel_rays(g, f.width, f.height, 32, radius, 0.5, true);
        std::vector<double> truth(got.size()), err(got.size());
        for (int y = 0; y < f.height; ++y)
            for (int x = 0; x < f.width; ++x)
                truth[std::size_t(y) * f.width + x] = f.h_minus_disk_mean(x, y, radius);
        for (std::size_t i = 0; i < got.size(); ++i)
            err[i] = got[i] - truth[i];
        const double rel = test::rms(err) / test::rms(truth);
        INFO("R = " << radius << ": RMS error / std = " << rel);
        CHECK(rel < 0.005);
    }
}

TEST_CASE("clip mode at edges and corners: a tilted plane against the clipped-disk integral", "[rays]")
{
    // For constant slopes the height along a ray is linear, so the weighted
    // mean over ray j of length L_j (clipped at the texture's edge) is exact:
    // A_j = (g.d)(L^3 - t0^3)/3, W_j = (L^2 - t0^2)/2 with t0 the extent of
    // the origin texel, which is excluded.
    const int w = 40, h = 30, rays = 24;
    const double radius = 12.0, phase = 0.5, gx = 0.7, gy = -0.4;
    std::vector<double> g(2 * std::size_t(w) * h);
    for (std::size_t i = 0; i < g.size(); i += 2) {
        g[i] = gx;
        g[i + 1] = gy;
    }
    auto got = kernel_rays(g, w, h, rays, radius, phase, false);

    std::vector<double> expect(got.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double a = 0, wsum = 0;
            for (int j = 0; j < rays; ++j) {
                double th = 2 * M_PI * (j + phase) / rays, dx = std::cos(th), dy = std::sin(th);
                double lx = dx > 0 ? (w - 0.5 - x) / dx : dx < 0 ? (x + 0.5) / -dx : 1e30;
                double ly = dy > 0 ? (h - 0.5 - y) / dy : dy < 0 ? (y + 0.5) / -dy : 1e30;
                double L = std::min({radius, lx, ly});
                double t0 = std::min({0.5 / std::abs(dx), 0.5 / std::abs(dy), L});
                a += (gx * dx + gy * dy) * (L * L * L - t0 * t0 * t0) / 3.0;
                wsum += (L * L - t0 * t0) / 2.0;
            }
            expect[std::size_t(y) * w + x] = -a / wsum;
        }
    relief::reference::subtract_mean(expect);
    const double spread = test::rms(expect);
    auto at = [&](int x, int y) { return std::size_t(y) * w + x; };
    for (auto [x, y] : {std::pair{0, 0},
                        {w - 1, 0},
                        {0, h - 1},
                        {w - 1, h - 1},
                        {0, h / 2},
                        {w / 2, 0},
                        {w - 1, h / 2},
                        {w / 2, h - 1},
                        {w / 2, h / 2}}) {
        INFO("texel " << x << "," << y);
        CHECK(std::abs(got[at(x, y)] - expect[at(x, y)]) < 0.01 * spread);
    }
    double worst = 0;
    for (std::size_t i = 0; i < got.size(); ++i)
        worst = std::max(worst, std::abs(got[i] - expect[i]));
    INFO("worst error " << worst << ", spread " << spread);
    CHECK(worst < 0.01 * spread);
}

TEST_CASE("a bump comes out positive (not upside down) through the public API", "[rays]")
{
    const int n = 64;
    std::vector<double> g(2 * n * n);
    auto hgt = [&](double x, double y) {
        return 5.0 * std::exp(-((x - 32) * (x - 32) + (y - 32) * (y - 32)) / 50.0);
    };
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            g[2 * (y * n + x)] = (hgt(x + 1e-4, y) - hgt(x - 1e-4, y)) / 2e-4;
            g[2 * (y * n + x) + 1] = (hgt(x, y + 1e-4) - hgt(x, y - 1e-4)) / 2e-4;
        }
    for (auto green : {test::Green::OpenGL, test::Green::DirectX}) {
        auto img = test::normal_image(g, n, n, green, OIIO::TypeDesc::UINT8);
        HeightOptions o;
        o.method = HeightMethod::Rays;
        o.rays = 16;
        o.radius = 24;
        auto out = relief::height(img, o);  // normal=auto
        REQUIRE_FALSE(out.has_error());
        float centre = 0, corner = 0;
        out.getpixel(32, 32, &centre, 1);
        out.getpixel(2, 2, &corner, 1);
        CHECK(centre > 3.0f);
        CHECK(corner < 0.5f);
        CHECK(out.spec().get_string_attribute("relief:height_unit") == "texel");
        CHECK(out.spec().get_string_attribute("relief:method") == "rays");
    }
}

TEST_CASE("a 1x1 texture integrates to zero without NaN", "[rays]")
{
    for (bool periodic : {true, false}) {
        auto got = kernel_rays({0.5, -0.25}, 1, 1, 8, 4.0, 0.5, periodic);
        CHECK(got[0] == 0.0f);
    }
}

TEST_CASE("bad height options fail with a message", "[rays][errors]")
{
    OIIO::ImageBuf img(OIIO::ImageSpec(8, 8, 3, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBuf out;
    HeightOptions o;
    o.rays = -3;
    CHECK_FALSE(relief::height(out, img, o));
    CHECK(relief::geterror().find("rays") != std::string::npos);
    o.rays = 8;
    o.radius = 0;
    CHECK_FALSE(relief::height(out, img, o));
    CHECK(relief::geterror().find("radius") != std::string::npos);
}

TEST_CASE("every ray integrator refuses rays < 1 and radius <= 0 as an internal error", "[rays]")
{
    // relief::validate() keeps these from the host; a caller that skips it
    // gets the host's own check, never a kernel launched with them.
    auto ctx = host::ComputeContext::acquire("auto");
    std::vector<float> gf(2 * 8 * 8, 0.0f), out(8 * 8);
    auto slopes = host::upload_slopes(*ctx, gf.data(), 8, 8);
    for (const auto& [rays, radius] : {std::pair{0, 4.0}, std::pair{8, 0.0}})
        for (const bool periodic : {false, true}) {
            INFO("rays " << rays << ", radius " << radius << ", periodic " << periodic);
            host::RayParams p;
            p.rays = rays;
            p.radius = radius;
            p.boundary = periodic ? host::RayBoundary::Periodic : host::RayBoundary::Clip;
            CHECK_THROWS_AS(host::integrate_rays_reference(*ctx, slopes, p, out.data()), host::InternalError);
            CHECK_THROWS_AS(host::integrate_rays_fast(*ctx, slopes, p, out.data()), host::InternalError);
        }
}
