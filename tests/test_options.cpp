// SPDX-License-Identifier: Apache-2.0
// The public API's options reach the host stages: for every option, the
// API's result equals the host call made with the same parameters (bit for
// bit: same device, same kernels), and the option changes the result, so
// an option that is ignored, swapped or given the wrong default fails.
// Also boundary=auto on synthetic tiling and non-tiling maps.
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

using namespace relief;
using OIIO::ImageBuf;
using OIIO::TypeDesc;
using test::max_abs_diff;
using test::pixels;
using test::waves;

namespace {

constexpr int kW = 48, kH = 40;

// Smooth tiling slopes plus non-integrable noise, so that every option that
// changes the integral shows.
std::vector<double> tiling_slopes(int w, int h, unsigned seed)
{
    test::PeriodicField f{w, h, {{1, 1, 3.0, 0.4}, {2, -1, 1.5, 1.3}, {5, 3, 0.4, 2.0}}};
    return test::plus_noise(f.slopes(), 0.1, seed);
}

// The slopes exactly as the API derives them from `normals`.
std::vector<float> api_slopes(const ImageBuf& normals)
{
    SlopeOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    ImageBuf s = relief::slopes(normals, o);
    REQUIRE_FALSE(s.has_error());
    return pixels(s);
}

std::vector<float> host_poisson(const std::vector<float>& g, int w, int h, const host::PoissonParams& p)
{
    auto ctx = host::ComputeContext::acquire("auto");
    auto d = host::upload_slopes(*ctx, g.data(), w, h);
    std::vector<float> out(std::size_t(w) * h);
    host::integrate_poisson(*ctx, d, p, out.data());
    return out;
}

std::vector<float> host_rays(const std::vector<float>& g, int w, int h, const host::RayParams& p, bool fast)
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

std::vector<float> api_height(const ImageBuf& normals, HeightOptions o, std::string* said = nullptr)
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

host::RayParams rays(int j, double r, double phase, bool periodic,
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

host::PoissonParams poisson_axes(bool periodic_x, bool periodic_y, double highpass = 0.0)
{
    host::PoissonParams p;
    p.boundary_x = periodic_x ? host::PoissonBoundary::Periodic : host::PoissonBoundary::Free;
    p.boundary_y = periodic_y ? host::PoissonBoundary::Periodic : host::PoissonBoundary::Free;
    p.highpass = highpass;
    return p;
}

host::PoissonParams poisson(bool periodic, double highpass = 0.0)
{
    return poisson_axes(periodic, periodic, highpass);
}

// Weights in [0, 1], a fifth of them 0.
std::vector<float> random_weights(std::size_t n, unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> w(n);
    for (float& v : w)
        v = u(rng) < 0.2f ? 0.0f : u(rng);
    return w;
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
        {"rays fast clip rays 12 radius 7 phase 0.25",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.boundary = Boundary::Free;
             o.rays = 12;
             o.radius = 7;
             o.phase = 0.25f;
         },
         [&](const auto& s) { return host_rays(s, w, h, rays(12, 7, 0.25, false), true); }},
        {"rays fast clip skip off",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.boundary = Boundary::Free;
             o.rays = 12;
             o.radius = 7;
             o.phase = 0.25f;
             o.skip_flat = false;
         },
         [&](const auto& s) {
             auto p = rays(12, 7, 0.25, false);
             p.skip_flat = false;
             return host_rays(s, w, h, p, true);
         }},
        {"rays reference periodic exact directions phase 0.125",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.boundary = Boundary::Periodic;
             o.impl = RayImpl::Reference;
             o.directions = RayDirections::Exact;
             o.rays = 6;
             o.radius = 9;
             o.phase = 0.125f;
         },
         [&](const auto& s) { return host_rays(s, w, h, rays(6, 9, 0.125, true, DS::Exact), false); }},
        {"rays reference periodic rational phase 0.125",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.boundary = Boundary::Periodic;
             o.impl = RayImpl::Reference;
             o.rays = 6;
             o.radius = 9;
             o.phase = 0.125f;
         },
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

TEST_CASE("options: mask=alpha and mask images weight the solve with their channel", "[options][mask]")
{
    const auto g = tiling_slopes(kW, kH, 5);
    const std::size_t n = std::size_t(kW) * kH;
    const auto weights = random_weights(n, 9);
    // RGBA normals whose alpha holds the weights.
    ImageBuf rgb = test::normal_image(g, kW, kH, test::Green::OpenGL, TypeDesc::FLOAT);
    const auto px = pixels(rgb);
    std::vector<float> rgba(4 * n);
    for (std::size_t i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c)
            rgba[4 * i + c] = px[3 * i + c];
        rgba[4 * i + 3] = weights[i];
    }
    const ImageBuf normals = test::image(kW, kH, 4, rgba);
    const auto slopes = api_slopes(rgb);
    const auto boundary = [](bool periodic) { return periodic ? Boundary::Periodic : Boundary::Free; };
    for (auto [px, py] :
         {std::pair{true, true}, std::pair{false, false}, std::pair{true, false}, std::pair{false, true}}) {
        INFO("periodic x " << px << ", y " << py);
        auto p = poisson_axes(px, py);
        p.weights = weights.data();
        const auto want = host_poisson(slopes, kW, kH, p);
        HeightOptions o;
        o.boundary = {boundary(px), boundary(py)};
        o.mask_alpha = true;
        const auto by_alpha = api_height(normals, o);
        CHECK(max_abs_diff(by_alpha, want) == 0.0);
        // A 3-channel mask image: channel 0 holds the weights, the others not.
        std::vector<float> m(3 * n);
        for (std::size_t i = 0; i < n; ++i) {
            m[3 * i] = weights[i];
            m[3 * i + 1] = 1.0f - weights[i];
            m[3 * i + 2] = 0.5f;
        }
        const ImageBuf mask = test::image(kW, kH, 3, m);
        o.mask_alpha = false;
        o.mask = &mask;
        CHECK(max_abs_diff(api_height(normals, o), want) == 0.0);
        // And the weights matter.
        const auto plain = host_poisson(slopes, kW, kH, poisson_axes(px, py));
        CHECK(max_abs_diff(want, plain) > 1e-3);
    }
}

namespace {

// The smallest RELIEF_MEMORY_LIMIT a height runs under, bisected to 1 KiB:
// its estimated need.
double smallest_memory_limit(const ImageBuf& normals, const HeightOptions& o)
{
    const auto runs = [&](std::uint64_t limit) {
        ::setenv("RELIEF_MEMORY_LIMIT", std::to_string(limit).c_str(), 1);
        ImageBuf out;
        const bool ok = relief::height(out, normals, o);
        if (!ok)
            CHECK(geterror().find("RELIEF_MEMORY_LIMIT") != std::string::npos);
        return ok;
    };
    std::uint64_t lo = 1024, hi = std::uint64_t(1) << 30;
    REQUIRE_FALSE(runs(lo));
    REQUIRE(runs(hi));
    while (hi - lo > 1024) {
        const std::uint64_t mid = lo + (hi - lo) / 2;
        (runs(mid) ? hi : lo) = mid;
    }
    ::unsetenv("RELIEF_MEMORY_LIMIT");
    return double(hi);
}

ImageBuf memory_test_normals(int n)
{
    std::vector<double> g(2 * std::size_t(n) * n);
    for (std::size_t i = 0; i < g.size(); ++i)
        g[i] = 0.2 * std::sin(0.05 * double(i));
    return test::normal_image(g, n, n, test::Green::OpenGL, TypeDesc::FLOAT);
}

}  // namespace

TEST_CASE("options: a mask's weights count in the memory a Poisson height is refused for",
          "[options][mask][memory]")
{
    // A mask makes the solve the weighted one, whose buffers (weights, the
    // conjugate-gradient vectors, the spectral start) the estimate must hold
    // on top of the plain solve's; on this CPU device the buffers are host
    // memory. Measured: 16 bytes a texel without a mask, 84 with one, for
    // either boundary.
    const int n = 256;
    const ImageBuf normals = memory_test_normals(n);
    const ImageBuf weights = test::image(n, n, 1, std::vector<float>(std::size_t(n) * n, 0.5f));
    for (Boundary b : {Boundary::Periodic, Boundary::Free}) {
        INFO((b == Boundary::Periodic ? "periodic" : "free"));
        HeightOptions plain;
        plain.method = HeightMethod::Poisson;
        plain.boundary = b;
        plain.normals.convention = NormalConvention::OpenGL;
        HeightOptions masked = plain;
        masked.mask = &weights;
        const double texels = double(n) * n, without = smallest_memory_limit(normals, plain),
                     with = smallest_memory_limit(normals, masked);
        std::printf("memory for a %dx%d Poisson height: %.1f bytes a texel, %.1f with a mask\n", n, n,
                    without / texels, with / texels);
        const bool unified = host::device_memory(*host::ComputeContext::acquire("auto")).host_unified;
        // The weighted solve's 16 floats a texel on the device, and on the
        // host its weights and spectral start (8 bytes): at least 64 bytes
        // a texel more where the device's buffers are host memory
        // (measured 68), 8 where they are not.
        CHECK(with - without >= (unified ? 64.0 : 8.0) * texels - 2048.0);  // (bisected to 1 KiB)
        // ... and the plain solve is not charged for them: a map that fits
        // is not refused.
        CHECK(without <= 20.0 * texels);
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
}

TEST_CASE("options: an all-ones mask changes nothing, one texel less does", "[options][mask]")
{
    const auto g = tiling_slopes(kW, kH, 6);
    const ImageBuf normals = test::normal_image(g, kW, kH, test::Green::OpenGL, TypeDesc::FLOAT);
    std::vector<float> ones(std::size_t(kW) * kH, 1.0f);
    for (bool periodic : {true, false}) {
        HeightOptions o;
        o.boundary = periodic ? Boundary::Periodic : Boundary::Free;
        const auto plain = api_height(normals, o);
        const ImageBuf mask = test::image(kW, kH, 1, ones, TypeDesc::UINT8);
        o.mask = &mask;
        std::string said;
        CHECK(api_height(normals, o, &said) == plain);
        CHECK(said.find("mask: all ones") != std::string::npos);
        std::vector<float> almost = ones;
        almost[kW * 7 + 11] = 0.0f;
        const ImageBuf hole = test::image(kW, kH, 1, almost);
        o.mask = &hole;
        said.clear();
        CHECK(max_abs_diff(api_height(normals, o, &said), plain) > 1e-4);
        CHECK(said.find("conjugate-gradient") != std::string::npos);
    }
}

TEST_CASE("options: boundary=auto integrates a tiling map periodically, a crop freely, a strip per axis",
          "[options][tiling]")
{
    // A tiling field, and the top-left 60 x 50 of a larger tiling field (its
    // wrap seams join unrelated texels).
    const int big_w = 96, big_h = 80, w = 60, h = 50;
    const auto tiling = tiling_slopes(big_w, big_h, 7);
    std::vector<double> crop(2 * std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 2; ++c)
                crop[2 * (std::size_t(y) * w + x) + c] = tiling[2 * (std::size_t(y) * big_w + x) + c];
    // And the left 60 columns at full height: only one seam joins unrelated texels.
    std::vector<double> strip(2 * std::size_t(w) * big_h);
    for (int y = 0; y < big_h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 2; ++c)
                strip[2 * (std::size_t(y) * w + x) + c] = tiling[2 * (std::size_t(y) * big_w + x) + c];
    const ImageBuf tile = test::normal_image(tiling, big_w, big_h, test::Green::OpenGL, TypeDesc::FLOAT);
    const ImageBuf part = test::normal_image(crop, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    const ImageBuf column = test::normal_image(strip, w, big_h, test::Green::OpenGL, TypeDesc::FLOAT);
    for (bool ray_method : {false, true}) {
        INFO((ray_method ? "rays" : "poisson"));
        HeightOptions o;
        if (ray_method) {
            o.method = HeightMethod::Rays;
            o.rays = 8;
            o.radius = 10;
        }
        // Each axis on its own: the strip integrates free along x, periodic
        // along y; rays take one boundary, clip unless both axes tile.
        const Boundaries periodic{Boundary::Periodic, Boundary::Periodic},
            free{Boundary::Free, Boundary::Free};
        const Boundaries strip_b = ray_method ? free : Boundaries{Boundary::Free, Boundary::Periodic};
        for (const auto& [img, chosen_b] :
             {std::pair{&tile, periodic}, std::pair{&part, free}, std::pair{&column, strip_b}}) {
            const bool tiles = chosen_b.x == Boundary::Periodic && chosen_b.y == Boundary::Periodic;
            std::string said;
            const auto got = api_height(*img, o, &said);
            HeightOptions explicit_b = o;
            explicit_b.boundary = chosen_b;
            const auto want = api_height(*img, explicit_b);
            INFO(said);
            CHECK(max_abs_diff(got, want) == 0.0);
            const auto word = [&](Boundary b) {
                return b == Boundary::Periodic ? "periodic" : (ray_method ? "clip" : "free");
            };
            const std::string chosen = chosen_b.x == chosen_b.y
                                           ? std::string(word(chosen_b.x))
                                           : std::string(word(chosen_b.x)) + "," + word(chosen_b.y);
            CHECK(said.find("boundary: " + chosen + " (") != std::string::npos);
            // relief:parameters records what was chosen, not "auto".
            HeightOptions again = o;
            again.normals.convention = NormalConvention::OpenGL;
            const std::string par =
                relief::height(*img, again).spec().get_string_attribute("relief:parameters");
            if (ray_method)
                CHECK(par ==
                      "method=rays impl=fast rays=8 radius=10 phase=0.5 directions=rational boundary=" +
                          chosen);
            else
                CHECK(par == "method=poisson boundary=" + chosen + " highpass=0");
            HeightOptions other = o;
            other.boundary = tiles ? Boundary::Free : Boundary::Periodic;
            CHECK(max_abs_diff(api_height(*img, other), got) > 1e-3);
        }
    }
}

TEST_CASE("options: a boundary per axis is kept, an axis left to auto takes its own verdict (both on auto "
          "too), the checks follow the height's",
          "[options][tiling]")
{
    // The left 60 columns of a tiling field at full height: it tiles along
    // y, and its x seam joins unrelated texels.
    const int big_w = 96, h = 80, w = 60;
    const auto tiling = tiling_slopes(big_w, h, 7);
    std::vector<double> strip(2 * std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 2; ++c)
                strip[2 * (std::size_t(y) * w + x) + c] = tiling[2 * (std::size_t(y) * big_w + x) + c];
    const ImageBuf column = test::normal_image(strip, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    const Boundaries fp{Boundary::Free, Boundary::Periodic};
    HeightOptions o;
    o.boundary = fp;
    HeightReport report;
    o.report = &report;
    const auto want = api_height(column, o);
    CHECK(report.boundary == "free,periodic");
    for (Boundaries half :
         {Boundaries{Boundary::Auto, Boundary::Periodic}, Boundaries{Boundary::Free, Boundary::Auto},
          Boundaries{Boundary::Auto, Boundary::Auto}}) {
        HeightOptions a;
        a.boundary = half;
        std::string said;
        CHECK(max_abs_diff(api_height(column, a, &said), want) == 0.0);
        INFO(said);
        CHECK(said.find("boundary: free,periodic (") != std::string::npos);
    }
    for (Boundary both : {Boundary::Free, Boundary::Periodic}) {
        HeightOptions other;
        other.boundary = both;
        CHECK(max_abs_diff(api_height(column, other), want) > 1e-3);
    }
    o.report = nullptr;
    o.normals.convention = NormalConvention::OpenGL;
    const ImageBuf height = relief::height(column, o);
    REQUIRE_FALSE(height.has_error());
    CHECK(height.spec().get_string_attribute("relief:parameters") ==
          "method=poisson boundary=free,periodic highpass=0");

    // --normals on auto reads the height's boundary per axis.
    const auto normals_of = [&](Boundaries b, std::string* said = nullptr) {
        NormalsOptions n;
        n.boundary = b;
        if (said)
            n.exec.on_message = [said](Severity, const std::string& m) { *said += m + "\n"; };
        const ImageBuf out = relief::normals(height, n);
        REQUIRE_FALSE(out.has_error());
        return pixels(out);
    };
    std::string said;
    const auto followed = normals_of(Boundary::Auto, &said);
    CHECK(said.find(
              "normals: boundary free,periodic (the height was integrated with boundary=free,periodic)") !=
          std::string::npos);
    CHECK(followed == normals_of(fp));
    CHECK(followed == normals_of({Boundary::Auto, Boundary::Periodic}));
    CHECK(max_abs_diff(followed, normals_of(Boundary::Free)) > 1e-3);
    CHECK(max_abs_diff(followed, normals_of(Boundary::Periodic)) > 1e-3);
}

TEST_CASE("options: boundary=auto integrates a map whose wrap seam was painted over periodically",
          "[options][tiling]")
{
    // Rough slopes on a smooth periodic surface, the first and last column
    // replaced by noise: the slope test fails the x seam, the block
    // heights still see the surface meet itself (0ad_desert_cliff's case).
    const int w = 384, h = 320;
    const test::PeriodicField f{w, h, {{3, 1, 40.0, 0.2}, {5, -4, 10.0, 1.0}, {11, 7, 3.0, 2.5}}};
    std::vector<double> g = test::plus_noise(f.slopes(), 1.5, 7);
    std::mt19937 rng(9);
    std::normal_distribution<double> noise(0.0, test::rms(g));
    for (int y = 0; y < h; ++y)
        for (int x : {0, w - 1})
            for (int c = 0; c < 2; ++c)
                g[2 * (std::size_t(y) * w + x) + c] = noise(rng);
    const ImageBuf img = test::normal_image(g, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    std::string said;
    const auto got = api_height(img, HeightOptions{}, &said);
    INFO(said);
    CHECK(said.find("boundary: periodic (x: ") != std::string::npos);
    CHECK(said.find("(fail), block heights step") != std::string::npos);
    HeightOptions periodic;
    periodic.boundary = Boundary::Periodic;
    CHECK(max_abs_diff(api_height(img, periodic), got) == 0.0);
}

namespace {

struct HostCorrection {
    std::vector<float> offsets;
    host::CorrectReport report;
};

HostCorrection host_correct(const std::vector<float>& hts, int w, int h, const host::CorrectParams& p)
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

ApiCorrection api_correct(const ImageBuf& height, CorrectOptions o)
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

}  // namespace

TEST_CASE("options: every correction option reaches the solver, the report is the solver's",
          "[options][correct]")
{
    const int w = 40, h = 36;
    const auto hts = waves(w, h, 1.0, 4);
    const ImageBuf height = test::image(w, h, 1, hts);
    // A fixation mask image (channel 0 = weights) and the tent's weights,
    // computed here from the documented formula max(0, 1 - |h - H0| / DH).
    std::vector<float> fix_px(3 * std::size_t(w) * h), fix(std::size_t(w) * h), tent(fix.size());
    for (std::size_t i = 0; i < fix.size(); ++i) {
        fix[i] = 2.0f + float(i % 7);
        fix_px[3 * i] = fix[i];
        fix_px[3 * i + 1] = 0.0f;
        fix_px[3 * i + 2] = 100.0f;
        tent[i] = std::max(0.0f, 1.0f - std::abs(hts[i] - 0.2f) / 0.5f);
    }
    const ImageBuf fix_image = test::image(w, h, 3, fix_px);

    struct Case {
        const char* name;
        std::function<void(CorrectOptions&)> api;
        std::function<void(host::CorrectParams&)> host;
    };
    // Every case starts from scale 0.3, centre nodes, periodic.
    const Case cases[] = {
        {"base", [](CorrectOptions&) {}, [](host::CorrectParams&) {}},
        {"theta 2", [](CorrectOptions& o) { o.theta = 2; }, [](host::CorrectParams& p) { p.theta = 2; }},
        {"theta 7.5", [](CorrectOptions& o) { o.theta = 7.5f; },
         [](host::CorrectParams& p) { p.theta = 7.5; }},
        {"corner nodes", [](CorrectOptions& o) { o.nodes = CorrectNodes::Corner; },
         [](host::CorrectParams& p) { p.corner_nodes = true; }},
        {"fixed boundary", [](CorrectOptions& o) { o.boundary = CorrectBoundary::Fixed; },
         [](host::CorrectParams& p) { p.periodic = false; }},
        {"corner nodes, fixed",
         [](CorrectOptions& o) {
             o.nodes = CorrectNodes::Corner;
             o.boundary = CorrectBoundary::Fixed;
         },
         [](host::CorrectParams& p) {
             p.corner_nodes = true;
             p.periodic = false;
         }},
        {"periodic,fixed",
         [](CorrectOptions& o) {
             o.boundary = {CorrectBoundary::Periodic, CorrectBoundary::Fixed};
         },
         [](host::CorrectParams& p) { p.periodic = host::Periodic(true, false); }},
        {"corner nodes, fixed,periodic",
         [](CorrectOptions& o) {
             o.nodes = CorrectNodes::Corner;
             o.boundary = {CorrectBoundary::Fixed, CorrectBoundary::Periodic};
         },
         [](host::CorrectParams& p) {
             p.corner_nodes = true;
             p.periodic = host::Periodic(false, true);
         }},
        {"corner nodes, polish 0",
         [](CorrectOptions& o) {
             o.nodes = CorrectNodes::Corner;
             o.polish = 0;
         },
         [](host::CorrectParams& p) {
             p.corner_nodes = true;
             p.polish = 0;
         }},
        {"corner nodes, polish 3",
         [](CorrectOptions& o) {
             o.nodes = CorrectNodes::Corner;
             o.polish = 3;
         },
         [](host::CorrectParams& p) {
             p.corner_nodes = true;
             p.polish = 3;
         }},
        {"scale 0.5", [](CorrectOptions& o) { o.scale = 0.5f; },
         [](host::CorrectParams& p) { p.scale = 0.5f; }},
        {"3 iterations", [](CorrectOptions& o) { o.iterations = 3; },
         [](host::CorrectParams& p) { p.iterations = 3; }},
        {"tolerance 1e-2", [](CorrectOptions& o) { o.tolerance = 1e-2f; },
         [](host::CorrectParams& p) { p.tolerance = 1e-2f; }},
        {"1 level", [](CorrectOptions& o) { o.levels = 1; }, [](host::CorrectParams& p) { p.levels = 1; }},
        {"threshold 3 (nothing to do)", [](CorrectOptions& o) { o.threshold = 3; },
         [](host::CorrectParams& p) { p.threshold = 3; }},
        {"fixation mask", [&](CorrectOptions& o) { o.fix_mask = &fix_image; },
         [&](host::CorrectParams& p) { p.fix_weights = fix.data(); }},
        {"fixation tent",
         [](CorrectOptions& o) {
             o.fix_height = 0.2f;
             o.fix_width = 0.5f;
         },
         [&](host::CorrectParams& p) { p.fix_weights = tent.data(); }},
        {"ternary search", [](CorrectOptions& o) { o.search = CorrectSearch::Ternary; },
         [](host::CorrectParams& p) { p.search = host::CorrectParams::Search::Ternary; }},
        {"golden search", [](CorrectOptions& o) { o.search = CorrectSearch::Golden; },
         [](host::CorrectParams& p) { p.search = host::CorrectParams::Search::Golden; }},
        {"relax 1.2", [](CorrectOptions& o) { o.relax = 1.2f; },
         [](host::CorrectParams& p) { p.relax = 1.2f; }},
        {"hats auto", [](CorrectOptions& o) { o.hats = CorrectHats::Auto; },
         [](host::CorrectParams& p) { p.hats = host::CorrectParams::Hats::Auto; }},
        {"hats always", [](CorrectOptions& o) { o.hats = CorrectHats::Always; },
         [](host::CorrectParams& p) { p.hats = host::CorrectParams::Hats::Always; }},
        {"global off", [](CorrectOptions& o) { o.global = CorrectGlobal::Off; },
         [](host::CorrectParams& p) { p.global = host::CorrectParams::Global::Off; }},
        {"global always", [](CorrectOptions& o) { o.global = CorrectGlobal::Always; },
         [](host::CorrectParams& p) { p.global = host::CorrectParams::Global::Always; }},
        {"skip off", [](CorrectOptions& o) { o.skip_tiles = false; },
         [](host::CorrectParams& p) { p.skip_tiles = false; }},
    };
    std::vector<std::vector<float>> results;
    for (const Case& c : cases) {
        INFO(c.name);
        CorrectOptions o;
        o.scale = 0.3f;
        o.nodes = CorrectNodes::Center;
        o.boundary = CorrectBoundary::Periodic;
        c.api(o);
        host::CorrectParams p;
        p.scale = 0.3f;
        p.corner_nodes = false;
        p.periodic = true;
        c.host(p);
        const ApiCorrection got = api_correct(height, o);
        const HostCorrection want = host_correct(hts, w, h, p);
        CHECK(max_abs_diff(got.offsets, want.offsets) == 0.0);
        const CorrectReport& r = got.report;
        CHECK(r.skipped == want.report.skipped);
        CHECK(r.energy_before == want.report.energy_before);
        CHECK(r.energy_after == want.report.energy_after);
        CHECK(r.iterations == want.report.total_iterations());
        CHECK(r.polish.iterations == want.report.polish.iterations);
        CHECK(r.polish.energy_start == want.report.polish.energy_start);
        CHECK(r.polish.energy_end == want.report.polish.energy_end);
        CHECK(r.polish.flipped == want.report.polish.flipped);
        CHECK(r.polish.repairs == want.report.polish.repairs);
        REQUIRE(r.levels.size() == want.report.levels.size());
        for (std::size_t l = 0; l < r.levels.size(); ++l) {
            const host::CorrectLevel& hl = want.report.levels[l];
            CHECK(r.levels[l].iterations == hl.iterations);
            CHECK(r.levels[l].energy_start == hl.energy_start);
            CHECK(r.levels[l].energy_end == hl.energy_end);
            CHECK(r.levels[l].width == hl.width);
            CHECK(r.levels[l].height == hl.height);
            CHECK(r.levels[l].converged == hl.converged);
            CHECK(r.levels[l].tiles_run == Approx(double(hl.tile_phases_run) / double(hl.tile_phases)));
            CHECK(r.levels[l].start_factor == hl.start_factor);
            CHECK(r.levels[l].hat_sweeps == hl.hat_sweeps);
        }
        for (const auto& [got_s, want_s] : {std::pair{r.anisotropy_before, want.report.anisotropy_before},
                                            std::pair{r.anisotropy_after, want.report.anisotropy_after},
                                            std::pair{r.area_before, want.report.area_before},
                                            std::pair{r.area_after, want.report.area_after}}) {
            CHECK(got_s.mean == want_s.mean);
            CHECK(got_s.p95 == want_s.p95);
            CHECK(got_s.max == want_s.max);
        }
        CHECK(r.width == w);
        CHECK(r.height == h);
        const auto json = nlohmann::json::parse(r.to_json());
        CHECK(json["width"] == 40);
        CHECK(json["height"] == 36);
        CHECK(json["levels"].size() == r.levels.size());
        CHECK(json["polish"].value("iterations", -1) == r.polish.iterations);
        CHECK(json["polish"].value("energy_end", -1.0) == r.polish.energy_end);
        for (std::size_t l = 0; l < r.levels.size(); ++l) {
            CHECK(json["levels"][l].value("start_factor", -1.0) == r.levels[l].start_factor);
            CHECK(json["levels"][l].value("hat_sweeps", -1) == r.levels[l].hat_sweeps);
        }
        const auto word = [](bool periodic) { return std::string(periodic ? "periodic" : "fixed"); };
        CHECK(r.boundary == (p.periodic.x == p.periodic.y ? word(p.periodic.x)
                                                          : word(p.periodic.x) + "," + word(p.periodic.y)));
        CHECK(r.nodes == (p.corner_nodes ? "corner" : "center"));
        CHECK(r.scale == Approx(p.scale));
        CHECK(got.image.spec().get_string_attribute("relief:boundary") == r.boundary);
        CHECK(got.image.spec().get_string_attribute("relief:nodes") == r.nodes);
        CHECK(got.image.spec().get_float_attribute("relief:scale") == Approx(p.scale));
        CHECK(got.image.spec().get_string_attribute("relief:method") == "correct");
        const std::string par = got.image.spec().get_string_attribute("relief:parameters");
        CHECK(par.find("theta=" + test::format_number(p.theta)) != std::string::npos);
        CHECK(par.find(" threshold=" + test::format_number(p.threshold)) != std::string::npos);
        CHECK(par.find("nodes=" + r.nodes) != std::string::npos);
        CHECK(par.find("boundary=" + r.boundary) != std::string::npos);
        CHECK(par.find(std::string(" hats=") + (p.hats == host::CorrectParams::Hats::Off      ? "off"
                                                : p.hats == host::CorrectParams::Hats::Always ? "always"
                                                                                              : "auto")) !=
              std::string::npos);
        CHECK(par.find(std::string(" global=") + (p.global == host::CorrectParams::Global::Off ? "off"
                                                  : p.global == host::CorrectParams::Global::Always
                                                      ? "always"
                                                      : "auto")) != std::string::npos);
        CHECK(par.find(" polish=" + std::to_string(p.corner_nodes ? p.polish : 0)) != std::string::npos);
        CHECK(r.polish.iterations == (p.corner_nodes && !r.skipped ? p.polish : 0));
        CHECK(par.find(" levels=" + (p.levels ? std::to_string(p.levels) : std::string("auto"))) !=
              std::string::npos);
        CHECK(par.find(" iterations=" + (p.iterations ? std::to_string(p.iterations)
                                                      : std::string("auto"))) != std::string::npos);
        if (!r.skipped) {
            CHECK(r.energy_after < r.energy_before * 0.999);
            CHECK(r.anisotropy_after.mean < r.anisotropy_before.mean);
        }
        results.push_back(got.offsets);
    }
    CHECK(results.back() == results.front());  // skip=off: the same bits
    for (std::size_t a = 0; a + 1 < results.size(); ++a)
        for (std::size_t b = a + 1; b + 1 < results.size(); ++b) {
            // On this map auto takes a global step after every iteration, as
            // always does; the max_iterations test tells them apart.
            if (std::string(cases[a].name) == "base" && std::string(cases[b].name) == "global always")
                continue;
            INFO(cases[a].name << " vs " << cases[b].name);
            CHECK(max_abs_diff(results[a], results[b]) > 1e-7);
        }
}

TEST_CASE("options: relief's own heights imply scale 1/width, others need one", "[options][correct]")
{
    const int w = 32, h = 24;
    const auto hts = waves(w, h, 3.0, 2);
    ImageBuf own = test::image(w, h, 1, hts);
    own.specmod().attribute("relief:height_unit", "texel");
    CorrectOptions o;
    o.nodes = CorrectNodes::Center;
    o.boundary = CorrectBoundary::Periodic;
    const ApiCorrection got = api_correct(own, o);
    host::CorrectParams p;
    p.scale = 1.0 / w;
    p.corner_nodes = false;
    p.periodic = true;
    CHECK(max_abs_diff(got.offsets, host_correct(hts, w, h, p).offsets) == 0.0);
    CHECK(got.report.scale == Approx(1.0 / w));
    CHECK_FALSE(got.report.skipped);
    ImageBuf other = test::image(w, h, 1, hts);
    ImageBuf dst;
    CHECK_FALSE(relief::correct(dst, other, o));
    CHECK(relief::geterror().find("scale") != std::string::npos);
}

TEST_CASE("options: correction boundary=auto finds tiling maps and crops", "[options][correct][tiling]")
{
    const int w = 48, h = 40;
    const auto hts = waves(w, h, 1.0, 11);
    // The top-left 30 x 26 of a tiling field does not tile; its left 30
    // columns tile along y only (the top/bottom seam continuous).
    auto cut = [&](int cw, int ch) {
        std::vector<float> crop(std::size_t(cw) * ch);
        for (int y = 0; y < ch; ++y)
            for (int x = 0; x < cw; ++x)
                crop[std::size_t(y) * cw + x] = hts[std::size_t(y) * w + x];
        return crop;
    };
    const auto crop = cut(30, 26), strip = cut(30, h);
    using B = CorrectBoundaries;
    for (const auto& [px, iw, ih, want, word] :
         {std::tuple{&hts, w, h, B(CorrectBoundary::Periodic), "periodic"},
          std::tuple{&crop, 30, 26, B(CorrectBoundary::Fixed), "fixed"},
          std::tuple{&strip, 30, h, B(CorrectBoundary::Fixed, CorrectBoundary::Periodic),
                     "fixed,periodic"}}) {
        INFO(iw << "x" << ih << ": " << word);
        const ImageBuf img = test::image(iw, ih, 1, *px);
        CorrectOptions o;
        o.scale = 0.3f;
        o.nodes = CorrectNodes::Center;
        const ApiCorrection got = api_correct(img, o);
        CHECK(got.report.boundary == word);
        CHECK(got.said.find(std::string("boundary ") + word + " (") != std::string::npos);
        o.boundary = want;
        CHECK(max_abs_diff(api_correct(img, o).offsets, got.offsets) == 0.0);
    }
}

TEST_CASE("options: bake filter and wrap reach the gather", "[options][bake]")
{
    const int w = 21, h = 17, nch = 2;
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), d(-0.08f, 0.08f);
    std::vector<float> src(std::size_t(w) * h * nch), off(2 * std::size_t(w) * h);
    for (float& v : src)
        v = u(rng);
    for (float& v : off)
        v = d(rng);
    const ImageBuf tex = test::image(w, h, nch, src), offsets = test::image(w, h, 2, off);
    auto ctx = host::ComputeContext::acquire("auto");
    std::vector<std::vector<float>> results;
    for (bool periodic : {false, true})
        for (bool bicubic : {false, true}) {
            INFO("periodic " << periodic << " bicubic " << bicubic);
            BakeOptions o;
            o.colorspace = BakeColorspace::Raw;
            o.filter = bicubic ? BakeFilter::Bicubic : BakeFilter::Bilinear;
            o.wrap = periodic ? BakeWrap::Periodic : BakeWrap::Clamp;
            ImageBuf out = relief::bake(tex, offsets, o);
            REQUIRE_FALSE(out.has_error());
            std::vector<float> want(src.size());
            host::bake_gather(*ctx, src.data(), w, h, nch, off.data(), periodic,
                              bicubic ? host::BakeFilter::Bicubic : host::BakeFilter::Bilinear, want.data());
            CHECK(pixels(out) == want);
            results.push_back(want);
        }
    for (std::size_t a = 0; a < results.size(); ++a)
        for (std::size_t b = a + 1; b < results.size(); ++b)
            CHECK(max_abs_diff(results[a], results[b]) > 1e-3);
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

TEST_CASE("options: correction skip=on skips still tiles, skip=off runs them all", "[options][correct]")
{
    // A bump in a flat sea, one level: far tiles have nothing to do.
    const int w = 96, h = 80;
    std::vector<float> hts(std::size_t(w) * h, 0.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double r2 = ((x - 20.0) * (x - 20.0) + (y - 18.0) * (y - 18.0)) / 25.0;
            hts[std::size_t(y) * w + x] = r2 < 9 ? float(std::exp(-r2)) : 0.0f;
        }
    const ImageBuf height = test::image(w, h, 1, hts);
    CorrectOptions o;
    o.scale = 0.15f;
    o.nodes = CorrectNodes::Center;
    o.boundary = CorrectBoundary::Periodic;
    o.levels = 1;
    o.global = CorrectGlobal::Off;  // global steps wake every tile
    const ApiCorrection on = api_correct(height, o);
    o.skip_tiles = false;
    const ApiCorrection off = api_correct(height, o);
    CHECK(max_abs_diff(on.offsets, off.offsets) == 0.0);
    CHECK(on.report.levels.back().tiles_run < 1.0);  // measured 0.984
    CHECK(off.report.levels.back().tiles_run == 1.0);
}

TEST_CASE("options: max_iterations stops a level that has not converged, and says so", "[options][correct]")
{
    const int w = 40, h = 36;
    const auto hts = waves(w, h, 1.0, 4);
    CorrectOptions o;
    o.scale = 0.3f;
    o.nodes = CorrectNodes::Center;
    o.boundary = CorrectBoundary::Periodic;
    o.levels = 1;
    o.max_iterations = 4;
    // A global step counts as the half iteration it costs: three
    // iterations, and steps after the first two (the third would pass the
    // limit).
    const ApiCorrection got = api_correct(test::image(w, h, 1, hts), o);
    REQUIRE(got.report.levels.size() == 1);
    CHECK(got.report.levels[0].iterations == 3);
    CHECK(got.report.levels[0].global_steps == 2);
    CHECK_FALSE(got.report.levels[0].converged);
    CHECK(got.said.find("stopped at 4 iterations (each global step counted as the iterations it costs)") !=
          std::string::npos);
    host::CorrectParams p;
    p.scale = 0.3f;
    p.corner_nodes = false;
    p.levels = 1;
    p.max_iterations = 4;
    CHECK(max_abs_diff(got.offsets, host_correct(hts, w, h, p).offsets) == 0.0);
    // global=always steps whatever the limit leaves.
    o.global = CorrectGlobal::Always;
    const ApiCorrection always = api_correct(test::image(w, h, 1, hts), o);
    CHECK(always.report.levels[0].iterations == 3);
    CHECK(always.report.levels[0].global_steps == 3);
    o.global = CorrectGlobal::Off;
    o.max_iterations = 2;
    const ApiCorrection plain = api_correct(test::image(w, h, 1, hts), o);
    CHECK(plain.report.levels[0].iterations == 2);
    CHECK(plain.said.find("stopped at 2 iterations before") != std::string::npos);
    // A level that swept says that its sweeps counted towards the limit.
    const int n = 128;
    o.scale = 1.0f;
    o.max_iterations = 60;
    o.tolerance = 1e-9f;
    o.hats = CorrectHats::Auto;
    o.global = CorrectGlobal::Off;
    const ApiCorrection swept = api_correct(test::image(n, n, 1, waves(n, n, 1.0, 23)), o);
    REQUIRE(swept.report.levels.size() == 1);
    CHECK(swept.report.levels[0].hat_sweeps > 0);
    CHECK(swept.said.find("stopped at 60 iterations (each hat sweep counted as the iterations it costs)") !=
          std::string::npos);
    CHECK(got.said.find("hat sweep") == std::string::npos);
    CHECK(swept.said.find("global step") == std::string::npos);
}

TEST_CASE("options: inconsistent or out-of-range options are refused by the API", "[options][errors]")
{
    const int w = 48, h = 40;
    const auto g = tiling_slopes(w, h, 8);
    const ImageBuf normals = test::normal_image(g, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    auto height_error = [&](const HeightOptions& o) {
        ImageBuf out;
        return relief::height(out, normals, o) ? std::string("accepted") : relief::geterror();
    };
    const ImageBuf short_mask = test::image(w, h - 1, 1, std::vector<float>(std::size_t(w) * (h - 1), 0.5f));
    const ImageBuf narrow_mask = test::image(w - 1, h, 1, std::vector<float>(std::size_t(w - 1) * h, 0.5f));
    const ImageBuf half_mask = test::image(w, h, 1, std::vector<float>(std::size_t(w) * h, 0.5f));
    std::vector<float> bad_values(std::size_t(w) * h, 0.5f);
    bad_values[17] = 1.5f;
    const ImageBuf over_mask = test::image(w, h, 1, bad_values);
    struct HCase {
        const char* what;
        std::function<void(HeightOptions&)> set;
        const char* message;
    };
    const HCase hcases[] = {
        {"mask one row short", [&](HeightOptions& o) { o.mask = &short_mask; }, "the mask is 48x39"},
        {"mask one column short", [&](HeightOptions& o) { o.mask = &narrow_mask; }, "the mask is 47x40"},
        {"mask value above 1", [&](HeightOptions& o) { o.mask = &over_mask; },
         "mask values must be in [0, 1]"},
        {"mask and rays",
         [&](HeightOptions& o) {
             o.mask = &half_mask;
             o.method = HeightMethod::Rays;
         },
         "mask applies to method=poisson"},
        {"mask and highpass",
         [&](HeightOptions& o) {
             o.mask = &half_mask;
             o.highpass = 8;
         },
         "highpass cannot be combined with a mask"},
        {"alpha mask and highpass",
         [&](HeightOptions& o) {
             o.mask_alpha = true;
             o.highpass = 8;
         },
         "highpass cannot be combined with a mask"},
        {"highpass and rays",
         [&](HeightOptions& o) {
             o.highpass = 8;
             o.method = HeightMethod::Rays;
         },
         "highpass applies to method=poisson"},
        {"phase 1", [](HeightOptions& o) { o.phase = 1.0f; },
         "phase=1 is out of range; it must be in [0, 1)"},
        {"phase negative", [](HeightOptions& o) { o.phase = -0.25f; },
         "phase=-0.25 is out of range; it must be in [0, 1)"},
        {"radius too large", [](HeightOptions& o) { o.radius = 70000.0f; }, "radius"},
        {"max_angle 90", [](HeightOptions& o) { o.normals.max_angle = 90.0f; },
         "max_angle=90 is out of range; it must be in (0, 90) degrees"},
        {"max_angle 0", [](HeightOptions& o) { o.normals.max_angle = 0.0f; }, "max_angle=0 is out of range"},
        {"fast with exact directions",
         [](HeightOptions& o) {
             o.method = HeightMethod::Rays;
             o.directions = RayDirections::Exact;
         },
         "impl=fast needs directions=rational"},
    };
    for (const HCase& c : hcases) {
        INFO(c.what);
        HeightOptions o;
        o.normals.convention = NormalConvention::OpenGL;
        c.set(o);
        const std::string e = height_error(o);
        INFO(e);
        CHECK(e.find(c.message) != std::string::npos);
        CHECK(e.rfind("height: ", 0) == 0);
    }

    const int cw = 40, ch = 36;
    const ImageBuf height = test::image(cw, ch, 1, waves(cw, ch, 1.0, 4));
    const ImageBuf tall_fix =
        test::image(cw, ch + 1, 1, std::vector<float>(std::size_t(cw) * (ch + 1), 1.0f));
    const ImageBuf wide_fix = test::image(cw + 1, ch, 1, std::vector<float>(std::size_t(cw + 1) * ch, 1.0f));
    std::vector<float> negative(std::size_t(cw) * ch, 1.0f);
    negative[5] = -1.0f;
    const ImageBuf negative_fix = test::image(cw, ch, 1, negative);
    struct CCase {
        const char* what;
        std::function<void(CorrectOptions&)> set;
        const char* message;
    };
    const CCase ccases[] = {
        {"fixation mask one row long", [&](CorrectOptions& o) { o.fix_mask = &tall_fix; },
         "the fixation mask is 40x37, the height map 40x36"},
        {"fixation mask one column wide", [&](CorrectOptions& o) { o.fix_mask = &wide_fix; },
         "the fixation mask is 41x36"},
        {"negative fixation weight", [&](CorrectOptions& o) { o.fix_mask = &negative_fix; },
         "fixation weights must be finite and >= 0"},
        {"mask and tent",
         [&](CorrectOptions& o) {
             o.fix_mask = &wide_fix;
             o.fix_width = 1;
         },
         "not both"},
        {"theta above 20", [](CorrectOptions& o) { o.theta = 20.5f; },
         "theta=20.5 is out of range; it must be in [0, 20]"},
        {"tolerance 0", [](CorrectOptions& o) { o.tolerance = 0.0f; },
         "tolerance=0 is out of range; it must be in (0, 1)"},
        {"negative threshold", [](CorrectOptions& o) { o.threshold = -1.0f; },
         "threshold=-1 is out of range; it must be in [0, 1e+09]"},
        {"polish above 1000", [](CorrectOptions& o) { o.polish = 1001; },
         "polish=1001 must be an integer in [0, 1000]"},
        {"negative levels", [](CorrectOptions& o) { o.levels = -1; },
         "levels=-1 must be an integer in [1, 30] or auto"},
        {"NaN scale", [](CorrectOptions& o) { o.scale = std::nanf(""); }, "scale=nan is not a number"},
    };
    for (const CCase& c : ccases) {
        INFO(c.what);
        CorrectOptions o;
        o.scale = 0.3f;
        c.set(o);
        ImageBuf out;
        CHECK_FALSE(relief::correct(out, height, o));
        const std::string e = relief::geterror();
        INFO(e);
        CHECK(e.find(c.message) != std::string::npos);
        CHECK(e.rfind("correct: ", 0) == 0);
    }
}

TEST_CASE("options: a failed call's returned image carries the error", "[options][errors]")
{
    const ImageBuf gray(OIIO::ImageSpec(8, 8, 1, TypeDesc::FLOAT));
    const ImageBuf s = relief::slopes(gray);
    CHECK(s.has_error());
    CHECK(s.geterror().find("slopes: unsupported channel count 1") != std::string::npos);
    const ImageBuf h = relief::height(gray);
    CHECK(h.has_error());
    CHECK(h.geterror().find("height: unsupported channel count 1") != std::string::npos);
    CorrectOptions co;
    co.scale = -1.0f;
    const ImageBuf c = relief::correct(gray, co);
    CHECK(c.has_error());
    CHECK(c.geterror().find("correct: scale=-1 is out of range; it must be in (0, 1e+09] or auto") !=
          std::string::npos);
    const ImageBuf b = relief::bake(gray, gray);
    CHECK(b.has_error());
    CHECK(b.geterror().find("bake: the offset map has 1 channel(s)") != std::string::npos);
}

TEST_CASE("options: a mask whose pixels cannot be read is an error, not an empty mask",
          "[options][mask][errors]")
{
    // An unread ImageBuf over a damaged file: its header reads, its pixels
    // do not. Ignoring the failed read excluded every texel silently.
    const int w = 48, h = 40;
    const auto g = tiling_slopes(w, h, 8);
    const ImageBuf normals = test::normal_image(g, w, h, test::Green::OpenGL, TypeDesc::FLOAT);
    const std::string dir = test::scratch("options-damaged-mask");
    const std::string whole = dir + "/whole.png", damaged = dir + "/damaged.png";
    {
        std::vector<float> noise(std::size_t(w) * h);
        for (std::size_t i = 0; i < noise.size(); ++i)
            noise[i] = float((i * 7919) % 251) / 250.0f;  // incompressible enough
        REQUIRE(test::image(w, h, 1, noise, TypeDesc::UINT8).write(whole));
        std::ifstream in(whole, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::ofstream(damaged, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    }
    const ImageBuf mask(damaged);
    REQUIRE(mask.spec().width == w);  // the header is intact
    HeightOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    o.mask = &mask;
    ImageBuf out;
    CHECK_FALSE(relief::height(out, normals, o));
    CHECK(relief::geterror().find("height: cannot read the mask") != std::string::npos);
}
