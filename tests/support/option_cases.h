// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the option tests share: tiling slopes, the API's and the host's
// results for the same options, the memory a height is refused under.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
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

namespace relief::test::options {

using test::max_abs_diff;
using test::pixels;
using test::waves;

using OIIO::ImageBuf;
using OIIO::TypeDesc;

constexpr int kW = 48, kH = 40;

// Smooth tiling slopes plus non-integrable noise, so that every option that
// changes the integral shows.
inline std::vector<double> tiling_slopes(int w, int h, unsigned seed)
{
    test::PeriodicField f{w, h, {{1, 1, 3.0, 0.4}, {2, -1, 1.5, 1.3}, {5, 3, 0.4, 2.0}}};
    return test::plus_noise(f.slopes(), 0.1, seed);
}

// The top-left w x h of slopes `g` (two per texel) of a map `gw` wide.
inline std::vector<double> top_left(const std::vector<double>& g, int gw, int w, int h)
{
    std::vector<double> out(2 * std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        std::copy_n(g.begin() + 2 * std::size_t(y) * gw, 2 * std::size_t(w),
                    out.begin() + 2 * std::size_t(y) * w);
    return out;
}

// The slopes exactly as the API derives them from `normals`.
inline std::vector<float> api_slopes(const ImageBuf& normals)
{
    SlopeOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    ImageBuf s = relief::slopes(normals, o);
    REQUIRE_FALSE(s.has_error());
    return pixels(s);
}

inline std::vector<float> host_poisson(const std::vector<float>& g, int w, int h,
                                       const host::PoissonParams& p)
{
    auto ctx = host::ComputeContext::acquire("auto");
    auto d = host::upload_slopes(*ctx, g.data(), w, h);
    std::vector<float> out(std::size_t(w) * h);
    host::integrate_poisson(*ctx, d, p, out.data());
    return out;
}

inline std::vector<float> host_rays(const std::vector<float>& g, int w, int h, const host::RayParams& p,
                                    bool fast)
{
    auto ctx = host::ComputeContext::acquire("auto");
    auto d = host::upload_slopes(*ctx, g.data(), w, h);
    std::vector<float> out(std::size_t(w) * h);
    if (fast)
        host::integrate_rays_fast(*ctx, d, p, out.data());
    else
        host::integrate_rays_reference(*ctx, d, p, out.data());
    return out;
}

inline std::vector<float> api_height(const ImageBuf& normals, HeightOptions o, std::string* said = nullptr)
{
    o.normals.convention = NormalConvention::OpenGL;
    if (said)
        o.exec.on_message = [said](Severity, const std::string& m) { *said += m + "\n"; };
    ImageBuf out = relief::height(normals, o);
    INFO(relief::geterror());
    REQUIRE_FALSE(out.has_error());
    return pixels(out);
}

struct HeightCase {
    const char* name;
    std::function<void(HeightOptions&)> api;
    std::function<std::vector<float>(const std::vector<float>&)> host;
};

inline host::RayParams rays(int j, double r, double phase, bool periodic,
                            host::DirectionSet d = host::DirectionSet::Rational)
{
    host::RayParams p;
    p.rays = j;
    p.radius = r;
    p.phase = phase;
    p.directions = d;
    p.boundary = periodic ? host::RayBoundary::Periodic : host::RayBoundary::Clip;
    return p;
}

inline host::PoissonParams poisson_axes(bool periodic_x, bool periodic_y, double highpass = 0.0)
{
    host::PoissonParams p;
    p.boundary_x = periodic_x ? host::PoissonBoundary::Periodic : host::PoissonBoundary::Free;
    p.boundary_y = periodic_y ? host::PoissonBoundary::Periodic : host::PoissonBoundary::Free;
    p.highpass = highpass;
    return p;
}

inline host::PoissonParams poisson(bool periodic, double highpass = 0.0)
{
    return poisson_axes(periodic, periodic, highpass);
}

// Weights in [0, 1], a fifth of them 0.
inline std::vector<float> random_weights(std::size_t n, unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> w(n);
    for (float& v : w)
        v = u(rng) < 0.2f ? 0.0f : u(rng);
    return w;
}
// The smallest RELIEF_MEMORY_LIMIT under which `runs` (a height: whether
// it succeeded) succeeds, bisected to 1 KiB: its estimated need.
template <class Runs>
double smallest_memory_limit(const Runs& runs)
{
    const auto under = [&](std::uint64_t limit) {
        ::setenv("RELIEF_MEMORY_LIMIT", std::to_string(limit).c_str(), 1);
        const bool ok = runs();
        if (!ok)
            CHECK(geterror().find("RELIEF_MEMORY_LIMIT") != std::string::npos);
        return ok;
    };
    std::uint64_t lo = 1024, hi = std::uint64_t(1) << 30;
    REQUIRE_FALSE(under(lo));
    REQUIRE(under(hi));
    while (hi - lo > 1024) {
        const std::uint64_t mid = lo + (hi - lo) / 2;
        (under(mid) ? hi : lo) = mid;
    }
    ::unsetenv("RELIEF_MEMORY_LIMIT");
    return double(hi);
}
inline double smallest_memory_limit(const ImageBuf& normals, const HeightOptions& o)
{
    return smallest_memory_limit([&] {
        ImageBuf out;
        return relief::height(out, normals, o);
    });
}

inline ImageBuf memory_test_normals(int n)
{
    std::vector<double> g(2 * std::size_t(n) * n);
    for (std::size_t i = 0; i < g.size(); ++i)
        g[i] = 0.2 * std::sin(0.05 * double(i));
    return test::normal_image(g, n, n, test::Green::OpenGL, TypeDesc::FLOAT);
}
struct HostCorrection {
    std::vector<float> offsets;
    host::CorrectReport report;
};

inline HostCorrection host_correct(const std::vector<float>& hts, int w, int h, const host::CorrectParams& p)
{
    auto ctx = host::ComputeContext::acquire("auto");
    HostCorrection r;
    r.offsets.resize(2 * std::size_t(w) * h);
    host::correct_distortion(*ctx, hts.data(), w, h, p, r.offsets.data(), &r.report);
    return r;
}

struct ApiCorrection {
    std::vector<float> offsets;
    CorrectReport report;
    ImageBuf image;
    std::string said;
};

inline ApiCorrection api_correct(const ImageBuf& height, CorrectOptions o)
{
    ApiCorrection r;
    o.report = &r.report;
    o.exec.on_message = [&r](Severity, const std::string& m) { r.said += m + "\n"; };
    r.image = relief::correct(height, o);
    INFO(relief::geterror());
    REQUIRE_FALSE(r.image.has_error());
    r.offsets = pixels(r.image);
    return r;
}

}  // namespace relief::test::options
