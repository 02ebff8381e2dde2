// SPDX-License-Identifier: Apache-2.0
// Masks weight the least-squares solve: mask=alpha and mask images, their
// memory, and what a mask that cannot be read is.
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
