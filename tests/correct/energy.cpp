// SPDX-License-Identifier: Apache-2.0
// Distortion correction: the energy against an SVD, the fan gradient against finite
// differences, the device's energy and statistics against the golden model.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <utility>

#include "device/compute_context.h"
#include "correct/correct_grid.h"
#include "correct/correct_stage.h"
#include "correct/correct_stop_rule.h"
#include "reference/correct_reference.h"
#include "relief/correct.h"
#include "relief/errors.h"
#include "support/fields.h"
#include "support/images.h"
#include "correct/correct_test.h"

using namespace relief;
using namespace relief::test::correction;

TEST_CASE("correct: closed-form triangle energy equals the SVD's", "[correct]")
{
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int checked = 0;
    for (int n = 0; n < 200; ++n) {
        const ref::Vec2 e1{1.0 + 0.4 * u(rng), 0.3 * u(rng)}, e2{0.3 * u(rng), -1.0 + 0.4 * u(rng)};
        const ref::Vec3 f1{1.0 + 0.2 * u(rng), 0.2 * u(rng), 3.0 * u(rng)},
            f2{0.2 * u(rng), -1.0 + 0.2 * u(rng), 3.0 * u(rng)};
        for (double theta : {0.0, 1.0, 5.0, 7.5}) {
            const auto sv = ref::triangle_singular_values(e1, e2, f1, f2);
            const double expect =
                (sv[0] / sv[1] + sv[1] / sv[0]) * std::pow(sv[0] * sv[1] + 1.0 / (sv[0] * sv[1]), theta);
            const double got = ref::triangle_energy(e1, e2, f1, f2, theta);
            REQUIRE(std::isfinite(got));
            REQUIRE(std::abs(got - expect) <= 1e-10 * expect);
            ++checked;
        }
    }
    CHECK(checked == 800);
    // A flipped texture triangle has infinite energy.
    CHECK(std::isinf(ref::triangle_energy({0.0, -1.0}, {1.0, 0.0}, {1, 0, 0}, {0, -1, 0}, 5.0)));
    // An isometry is the minimum 2 * 2^theta.
    CHECK(ref::triangle_energy({1.0, 0.0}, {1.0, -1.0}, {1, 0, 0}, {1, -1, 0}, 5.0) ==
          Approx(64.0).epsilon(1e-14));
}

TEST_CASE("correct: analytic fan gradient equals finite differences", "[correct]")
{
    const int w = 9, h = 8;
    for (bool periodic : {true, false})
        for (bool with_fix : {false, true}) {
            ref::CorrectionGrid g = centre_grid(waves(w, h, 1.0, 3), w, h, 0.3, periodic);
            if (with_fix)
                g.fix.assign(std::size_t(w) * h, 0.4);
            std::mt19937 rng(11);
            std::uniform_real_distribution<double> u(-0.15, 0.15);
            std::vector<double> c(2 * std::size_t(w) * h);
            for (double& v : c)
                v = u(rng);
            double worst = 0.0;
            for (int j = 1; j < h - 1; ++j)
                for (int i = 1; i < w - 1; ++i) {
                    const auto grad = ref::fan_gradient(g, c, i, j);
                    for (int d = 0; d < 2; ++d) {
                        const double step = 1e-6;
                        auto cp = c, cm = c;
                        cp[2 * (j * w + i) + d] += step;
                        cm[2 * (j * w + i) + d] -= step;
                        const double fd =
                            (ref::fan_energy(g, cp, i, j) - ref::fan_energy(g, cm, i, j)) / (2 * step);
                        // The whole energy changes only through p's fan.
                        const double fd_total =
                            (ref::total_energy(g, cp) - ref::total_energy(g, cm)) / (2 * step);
                        worst = std::max(worst, std::abs(grad[d] - fd) / (1.0 + std::abs(fd)));
                        REQUIRE(std::abs(fd_total - fd) <= 1e-5 * (1.0 + std::abs(fd)));
                    }
                }
            INFO("periodic " << periodic << " fix " << with_fix);
            CHECK(worst < 1e-6);
        }
}

TEST_CASE("correct: device energy equals the golden model's", "[correct]")
{
    const int w = 21, h = 13;
    const auto hts = waves(w, h, 1.0, 5);
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> u(-0.1, 0.1);
    // Both axes, neither, and one periodic axis with the other fixed.
    for (const host::Periodic periodic : {host::Periodic(true), host::Periodic(false),
                                          host::Periodic(true, false), host::Periodic(false, true)}) {
        const ref::CorrectionGrid g = centre_grid(hts, w, h, 0.2, periodic);
        std::vector<double> c(2 * std::size_t(w) * h);
        std::vector<float> tex(c.size());
        for (std::size_t k = 0; k < c.size(); ++k) {
            c[k] = u(rng);
            const int i = int(k / 2) % w, j = int(k / 2) / w;
            if ((!periodic.x && (i == 0 || i == w - 1)) || (!periodic.y && (j == 0 || j == h - 1)))
                c[k] = 0.0;
            tex[k] = float(c[k] / (k % 2 ? h : w));  // texture units
        }
        auto ctx = host::ComputeContext::acquire("auto");
        const double dev = host::correction_energy(*ctx, hts.data(), w, h, params(0.2, periodic), tex.data());
        const double gold = ref::total_energy(g, c);
        INFO("periodic x " << periodic.x << " y " << periodic.y);
        CHECK(std::abs(dev - gold) <= 1e-5 * gold);
    }
}

TEST_CASE("correct: the distortion statistics are the triangles' singular values", "[correct]")
{
    // Zero offsets on a centre-node periodic grid: every node owns
    // [p, p+(1,0), p+(1,-1)] and [p, p+(1,-1), p+(0,-1)] (texels, y down).
    // The larger map puts hundreds of triangles in each range of values
    // that the percentile's first pass tells apart (its keys' top 16 bits).
    const auto size = GENERATE(std::pair{9, 8}, std::pair{96, 80});
    const int w = size.first, h = size.second;
    CAPTURE(w, h);
    const double scale = 0.3;
    const auto hts = waves(w, h, 1.0, 14);
    auto z = [&](int i, int j) {
        return double(hts[std::size_t((j + h) % h) * w + (i + w) % w]) * scale * w;
    };
    std::vector<double> aniso, area;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            for (int t = 0; t < 2; ++t) {
                const ref::Vec2 e1 = t == 0 ? ref::Vec2{1, 0} : ref::Vec2{1, -1};
                const ref::Vec2 e2 = t == 0 ? ref::Vec2{1, -1} : ref::Vec2{0, -1};
                const ref::Vec3 f1{e1[0], e1[1], z(i + int(e1[0]), j + int(e1[1])) - z(i, j)};
                const ref::Vec3 f2{e2[0], e2[1], z(i + int(e2[0]), j + int(e2[1])) - z(i, j)};
                const auto sv = ref::triangle_singular_values(e1, e2, f1, f2);
                aniso.push_back(sv[0] / sv[1]);
                area.push_back(sv[0] * sv[1]);
            }
    auto p95 = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        return v[std::size_t(std::ceil(0.95 * double(v.size()))) - 1];
    };
    auto mean = [](const std::vector<double>& v) {
        double s = 0;
        for (double x : v)
            s += x;
        return s / double(v.size());
    };
    auto ctx = host::ComputeContext::acquire("auto");
    const std::vector<float> zero(2 * std::size_t(w) * h, 0.0f);
    host::DistortionStats a, r;
    host::correction_energy(*ctx, hts.data(), w, h, params(scale, true), zero.data(), &a, &r);
    CHECK(a.mean == Approx(mean(aniso)).epsilon(1e-5));
    CHECK(a.p95 == Approx(p95(aniso)).epsilon(1e-5));
    CHECK(a.max == Approx(*std::max_element(aniso.begin(), aniso.end())).epsilon(1e-5));
    CHECK(r.mean == Approx(mean(area)).epsilon(1e-5));
    CHECK(r.p95 == Approx(p95(area)).epsilon(1e-5));
    CHECK(r.max == Approx(*std::max_element(area.begin(), area.end())).epsilon(1e-5));
}

TEST_CASE("correct: statistics larger than one device buffer come in chunks, same bits", "[correct]")
{
    // 16 bytes of statistics per node passed the 4 GiB allocation limit of
    // PoCL at 16384^2. A cap between the offsets' 8 and the statistics' 16
    // bytes per node makes them come in chunks here (of whole work-groups
    // of the sum: 8 nodes a work-item).
    const int w = 96, h = 96;
    const auto hts = waves(w, h, 1.0, 4);
    auto p = params(0.4, true, false);
    p.levels = 1;
    p.iterations = 3;
    host::CorrectReport whole, chunked;
    const auto a = run(hts, w, h, p, &whole);
    ::setenv("RELIEF_DEVICE_MAX_ALLOC", "100000", 1);
    std::vector<float> b;
    try {
        b = run(hts, w, h, p, &chunked);
    } catch (...) {
        ::unsetenv("RELIEF_DEVICE_MAX_ALLOC");
        throw;
    }
    ::unsetenv("RELIEF_DEVICE_MAX_ALLOC");
    CHECK(a == b);
    CHECK(whole.energy_before == chunked.energy_before);
    CHECK(whole.energy_after == chunked.energy_after);
    CHECK(whole.anisotropy_after.p95 == chunked.anisotropy_after.p95);
    CHECK(whole.area_after.max == chunked.area_after.max);
    CHECK(whole.area_before.mean == chunked.area_before.mean);
}
