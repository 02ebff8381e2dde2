// SPDX-License-Identifier: Apache-2.0
// --tessellation: the levels against the golden model.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <tiny_gltf.h>

#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <random>

#include "check/check_stage.h"
#include "device/compute_context.h"
#include "reference/check_reference.h"
#include "reference/ddm_reference.h"
#include "relief/check.h"
#include "relief/errors.h"
#include "relief/height.h"
#include "relief/imageio.h"
#include "relief/mesh.h"
#include "relief/preview.h"
#include "relief/relief_c.h"
#include "relief/slopes.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/run_cli.h"
#include "check/check_test.h"

using namespace relief;
using namespace relief::test::checks;

TEST_CASE("tessellation: the device's levels are the golden model's", "[check]")
{
    for (auto [w, ht, patch] : {std::tuple{70, 45, 16}, std::tuple{64, 64, 32}, std::tuple{33, 17, 8}}) {
        const std::vector<float> hf = test::waves(w, ht, 6.0, unsigned(w));
        const auto err = reference::tessellation_errors(as_double(hf), w, ht, patch, 2.0);
        for (float e : {0.05f, 0.5f}) {
            TessellationOptions o;
            o.patch = patch;
            o.error = e;
            o.scale = 2.0f;
            OIIO::ImageBuf lv = relief::tessellation(test::image(w, ht, 1, hf), o);
            REQUIRE(lv.spec().width == (w + patch - 1) / patch);
            REQUIRE(lv.spec().height == (ht + patch - 1) / patch);
            const auto got = test::pixels(lv);
            for (std::size_t p = 0; p < got.size(); ++p) {
                int want = 64;
                for (int L = 64; L >= 1; --L)
                    if (err[p * 64 + L - 1] <= e)
                        want = L;
                // float against double: only a level whose error is within
                // 1e-4 of E may come out the other way.
                bool borderline = false;
                for (int L = 1; L <= 64; ++L)
                    borderline |= std::abs(err[p * 64 + L - 1] - e) < 1e-4;
                INFO(w << "x" << ht << " patch " << patch << " E " << e << " p " << p);
                if (!borderline)
                    CHECK(got[p] == want);
            }
        }
    }
}

TEST_CASE("tessellation: flat patches get level 1, detail more", "[check]")
{
    // A 512^2 map whose left half is flat.
    const int w = 512, ht = 512;
    std::vector<float> h = test::waves(w, ht, 20.0, 3);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w / 2; ++x)
            h[std::size_t(y) * w + x] = 1.5f;
    TessellationOptions o;
    o.patch = 32;
    o.error = 0.1f;
    CHECK(
        relief::tessellation(test::image(w, ht, 1, h), o).spec().get_string_attribute("relief:parameters") ==
        "patch=32 error=0.1 scale=1");  // as the modifiers are written, not error=0.100000001
    o.error = 0.5f;
    const auto lv = test::pixels(relief::tessellation(test::image(w, ht, 1, h), o));
    REQUIRE(lv.size() == 16 * 16);
    int raised = 0;
    for (int py = 0; py < 16; ++py)
        for (int px = 0; px < 16; ++px) {
            INFO(px << ", " << py);
            if (px < 8)
                CHECK(lv[py * 16 + px] == 1.0f);
            else
                raised += lv[py * 16 + px] > 1.0f;
        }
    // Waves of amplitude 20 bend more than 0.5 texel over most 32-texel patches.
    CHECK(raised > 100);
}

TEST_CASE("tessellation: patch=1 and patches larger than the map", "[check]")
{
    // One level per texel: a single texel is flat, so level 1 everywhere.
    const std::vector<float> h = test::waves(13, 9, 4.0, 4);
    TessellationOptions o;
    o.patch = 1;
    const OIIO::ImageBuf one = relief::tessellation(test::image(13, 9, 1, h), o);
    REQUIRE(one.spec().width == 13);
    REQUIRE(one.spec().height == 9);
    for (float v : test::pixels(one))
        CHECK(v == 1.0f);
    // One patch over the whole map, as the golden model says.
    o.patch = 64;
    o.error = 0.05f;
    const auto got = test::pixels(relief::tessellation(test::image(13, 9, 1, h), o));
    REQUIRE(got.size() == 1);
    const auto err = reference::tessellation_errors(as_double(h), 13, 9, 64, 1.0);
    int want = 64;
    bool borderline = false;
    for (int L = 64; L >= 1; --L) {
        if (err[std::size_t(L - 1)] <= 0.05)
            want = L;
        borderline |= std::abs(err[std::size_t(L - 1)] - 0.05) < 1e-4;
    }
    if (!borderline)
        CHECK(got[0] == want);
}

TEST_CASE("tessellation: per-patch and per-level launches give the same levels as the golden model",
          "[check]")
{
    auto ctx = host::ComputeContext::acquire("auto");
    for (auto [w, ht, patch, e] : {std::tuple{200, 150, 8, 0.3f}, std::tuple{131, 77, 40, 0.1f}}) {
        const std::vector<float> h = test::waves(w, ht, 15.0, unsigned(ht));
        const auto a = host::tessellation_levels(*ctx, h.data(), w, ht, patch, e, 1.0f,
                                                 host::TessellationLaunch::PerPatch);
        const auto b = host::tessellation_levels(*ctx, h.data(), w, ht, patch, e, 1.0f,
                                                 host::TessellationLaunch::PerLevel);
        INFO(w << "x" << ht << " patch " << patch);
        CHECK(a == b);
        const auto err = reference::tessellation_errors(as_double(h), w, ht, patch, 1.0);
        int compared = 0;
        for (std::size_t p = 0; p < a.size(); ++p) {
            int want = 0;
            bool borderline = false;
            for (int L = 64; L >= 1; --L) {
                if (err[p * 64 + L - 1] <= e)
                    want = L;
                borderline |= std::abs(err[p * 64 + L - 1] - e) < 1e-4;
            }
            if (borderline)
                continue;
            CHECK(int(a[p]) == want);
            ++compared;
        }
        CHECK(compared > int(a.size()) / 2);
        CHECK(*std::max_element(a.begin(), a.end()) > 2);
    }
}

TEST_CASE("tessellation: the levels' shares and the patches no level brings within E, as said", "[check]")
{
    // A row of 4 patches of 128 texels: flat (level 1), a gentle bump (a
    // middle level), and two near the Nyquist rate, which even level 64 (a
    // vertex every 2 texels) leaves far from the height. A patch's edge
    // vertices sample its neighbours' texels: the bump is 2 at both ends,
    // and the fast waves start 8 texels into their patches.
    const int w = 512, ht = 128, patch = 128;
    const float pi = 3.14159265f;
    std::vector<float> h(std::size_t(w) * ht, 2.0f);
    for (int y = 0; y < ht; ++y)
        for (int x = patch; x < w; ++x) {
            float& v = h[std::size_t(y) * w + x];
            if (x < 2 * patch)
                v = 2.0f + 4.0f * std::sin(pi * float(x - patch) / float(patch)) * std::cos(float(y) * 0.03f);
            else if (x >= 2 * patch + 8)
                v = 2.0f + 3.0f * std::sin(float(x) * 2.5f) * std::cos(float(y) * 2.1f);
        }
    const float e = 0.5f;
    const auto err = reference::tessellation_errors(as_double(h), w, ht, patch, 1.0);
    std::vector<int> levels;
    for (std::size_t p = 0; p < 4; ++p) {
        int level = 0;
        for (int L = 64; L >= 1; --L) {
            REQUIRE(std::abs(err[p * 64 + L - 1] - e) >= 1e-4);  // (no level on the edge of E)
            if (err[p * 64 + L - 1] <= e)
                level = L;
        }
        levels.push_back(level);
    }
    REQUIRE(levels[0] == 1);
    REQUIRE(levels[1] > 1);
    REQUIRE(levels[1] < 64);
    REQUIRE(levels[2] == 0);
    REQUIRE(levels[3] == 0);

    std::vector<std::pair<Severity, std::string>> said;
    TessellationOptions o;
    o.patch = patch;
    o.error = e;
    o.exec.on_message = [&said](Severity s, const std::string& m) { said.emplace_back(s, m); };
    const auto lv = test::pixels(relief::tessellation(test::image(w, ht, 1, h), o));
    CHECK(lv == std::vector<float>{1.0f, float(levels[1]), 64.0f, 64.0f});
    const std::vector<std::pair<Severity, std::string>> want = {
        {Severity::Warning, "tessellation: 2 of 4 patch(es) exceed error=0.5 even at level 64; they get 64 "
                            "(use a smaller patch)"},
        {Severity::Info, "tessellation: 4x1 patches of 128 texels: level 1 25.0%, level " +
                             std::to_string(levels[1]) + " 25.0%, none within E (set to 64) 50.0%"},
    };
    CHECK(said == want);
    // Every patch within E at some level: no warning.
    said.clear();
    o.error = 10.0f;
    CHECK(test::pixels(relief::tessellation(test::image(w, ht, 1, h), o)) == std::vector<float>(4, 1.0f));
    CHECK(said == std::vector<std::pair<Severity, std::string>>{
                      {Severity::Info, "tessellation: 4x1 patches of 128 texels: level 1 100.0%"}});
}
