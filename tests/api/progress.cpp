// SPDX-License-Identifier: Apache-2.0
// What a host hears while an operation runs, and how it stops one: the
// heartbeat and the final call (detail::paced), cancel within a long pass,
// and a map too large for memory refused before its input is copied.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "callbacks.h"
#include "relief/operations.h"
#include "relief/relief_c.h"
#include "support/fields.h"
#include "support/scoped_env.h"

using namespace relief;

namespace {

// What a C host heard, and the progress call (1, 2, ...) it answers
// non-zero to; -1: the call that reports 1.
struct Host {
    std::vector<double> progress;
    int answer_at = 0;
    std::chrono::steady_clock::time_point answered;  // (when it answered non-zero)
    const relief_image* result = nullptr;            // (the call's output, looked at on hearing 1)
    bool result_at_one = false;                      // (its pixels were there when 1 was heard)
};

int heard(double fraction, void* user)
{
    Host& h = *static_cast<Host*>(user);
    h.progress.push_back(fraction);
    if (fraction >= 1.0 && h.result)
        h.result_at_one = h.result->pixels != nullptr;
    const bool stop = h.answer_at < 0 ? fraction >= 1.0 : int(h.progress.size()) == h.answer_at;
    if (stop)
        h.answered = std::chrono::steady_clock::now();
    return stop;
}

// Normals of a rippled surface (OpenGL), float.
std::vector<float> ripples(int n)
{
    std::vector<float> px(3 * std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double out[3];
            test::encode_normal(0.4 * std::sin(0.21 * x) * std::cos(0.13 * y), 0.3 * std::cos(0.17 * y),
                                test::Green::OpenGL, out);
            for (int c = 0; c < 3; ++c)
                px[3 * (std::size_t(y) * n + x) + std::size_t(c)] = float(out[c]);
        }
    return px;
}

}  // namespace

TEST_CASE("progress: the heartbeat repeats the last fraction, only the table reports 1", "[progress]")
{
    std::vector<double> fractions;
    int asked = 0;
    bool stop = false;
    Execution exec;
    exec.on_progress = [&](double f) { fractions.push_back(f); };
    exec.cancel = [&] {
        ++asked;
        return stop;
    };
    SECTION("every cancel after the interval hears the last fraction again")
    {
        const Execution e = detail::paced(exec, std::chrono::seconds(0));
        CHECK(!e.cancel());
        e.on_progress(0.25);
        CHECK(!e.cancel());
        CHECK(!e.cancel());
        CHECK(fractions == std::vector<double>{0.0, 0.25, 0.25, 0.25});
        CHECK(asked == 6);  // asked before and after each heartbeat
    }
    SECTION("a fraction heard starts the interval again")
    {
        const Execution e = detail::paced(exec, std::chrono::milliseconds(200));
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
        e.on_progress(0.5);
        CHECK(!e.cancel());  // (heard just now: no repeat)
        CHECK(fractions == std::vector<double>{0.5});
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
        CHECK(!e.cancel());
        CHECK(fractions == std::vector<double>{0.5, 0.5});
    }
    SECTION("within the interval, nothing is repeated")
    {
        const Execution e = detail::paced(exec, std::chrono::hours(1));
        e.on_progress(0.5);
        CHECK(!e.cancel());
        CHECK(fractions == std::vector<double>{0.5});
    }
    SECTION("a stage's own 1 is held back for the table's last call")
    {
        const Execution e = detail::paced(exec, std::chrono::seconds(0));
        e.on_progress(0.5);
        e.on_progress(1.0);
        CHECK(!e.cancel());
        CHECK(fractions == std::vector<double>{0.5, 0.5});
    }
    SECTION("once the host has asked to stop, no heartbeat")
    {
        const Execution e = detail::paced(exec, std::chrono::seconds(0));
        stop = true;
        CHECK(e.cancel());
        CHECK(fractions.empty());
    }
    SECTION("without progress the Execution is the host's own")
    {
        exec.on_progress = nullptr;
        const Execution e = detail::paced(exec, std::chrono::seconds(0));
        CHECK(!e.on_progress);
        CHECK(!e.cancel());
        CHECK(asked == 1);
    }
}

TEST_CASE("C ABI: a cancel answered to the last progress call comes after the work: the result is returned",
          "[progress][abi]")
{
    const int n = 48;
    std::vector<float> normals = ripples(n);
    std::vector<float> height = test::waves(n, n, 2.0, 3);
    std::vector<float> offsets(2 * std::size_t(n) * n, 0.001f), texture(3 * std::size_t(n) * n, 0.5f);
    const relief_image in_n = {n, n, 3, RELIEF_FLOAT, normals.data(), nullptr};
    const relief_image in_h = {n, n, 1, RELIEF_FLOAT, height.data(), nullptr};
    const relief_image in_t = {n, n, 3, RELIEF_FLOAT, texture.data(), nullptr};
    const relief_image in_o = {n, n, 2, RELIEF_FLOAT, offsets.data(), nullptr};
    struct Case {
        const char* operation;
        const char* modifiers;
        std::vector<relief_image> inputs;
    };
    // (reference rays and centre nodes had returned CANCELLED here: their
    // stages reported 1 before their last kernels)
    const std::vector<Case> cases = {
        {"slopes", "normal=opengl", {in_n}},
        {"height", "normal=opengl", {in_n}},
        {"height", "normal=opengl:method=rays:impl=reference:rays=8:radius=8", {in_n}},
        {"height", "normal=opengl:method=rays", {in_n}},
        {"correct", "scale=0.3:nodes=center", {in_h}},
        {"correct", "scale=0.3:nodes=corner", {in_h}},
        {"bake", "", {in_t, in_o}},
        {"normals", "", {in_h}},
        {"tessellation", "", {in_h}},
        {"preview", "normal=opengl", {in_n, in_h}},
    };
    for (const Case& c : cases) {
        INFO(c.operation << ":" << c.modifiers);
        Host host;
        host.answer_at = -1;
        relief_callbacks cb = {nullptr, heard, &host};
        relief_image out{};
        host.result = &out;
        REQUIRE(relief_run_with("auto", c.operation, c.modifiers, c.inputs.data(), int(c.inputs.size()), &out,
                                &cb) == RELIEF_OK);
        CHECK(out.pixels != nullptr);
        // 1 is heard once the result is the host's (converting a large one
        // takes a while, and the host could still cancel during it)
        CHECK(host.result_at_one);
        REQUIRE(!host.progress.empty());
        CHECK(host.progress.back() == 1.0);
        CHECK(std::count(host.progress.begin(), host.progress.end(), 1.0) == 1);  // the last call only
        relief_image plain{};
        REQUIRE(relief_run_on("auto", c.operation, c.modifiers, c.inputs.data(), int(c.inputs.size()),
                              &plain) == RELIEF_OK);
        const std::size_t values = std::size_t(out.width) * out.height * out.channels;
        REQUIRE(std::size_t(plain.width) * plain.height * plain.channels == values);
        CHECK(std::memcmp(out.pixels, plain.pixels, values * sizeof(float)) == 0);
        relief_image_free(&out);
        relief_image_free(&plain);
    }
}

TEST_CASE("C ABI: a long pass asks its host while it runs, and stops part way", "[progress][abi]")
{
    // One launch over the whole map had been the tessellation's only work:
    // its host heard 0 and 1 and no cancel could reach it. In parts, the
    // host hears the heartbeat and its answer stops the run. (Columns of
    // cliffs: patches that need high levels, 0.4 s here.)
    const int n = 1024;
    std::vector<float> height(std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            height[std::size_t(y) * n + std::size_t(x)] =
                float((x / 64) % 2) * 8.0f + 3.0f * std::sin(y * 0.05f) * std::cos(x * 0.03f);
    const relief_image in = {n, n, 1, RELIEF_FLOAT, height.data(), nullptr};
    relief_image out{};
    REQUIRE(relief_run_on("auto", "tessellation", "", &in, 1, &out) == RELIEF_OK);  // (set-up, not timed)
    relief_image_free(&out);
    Host listens;
    relief_callbacks cb = {nullptr, heard, &listens};
    const auto start = std::chrono::steady_clock::now();
    REQUIRE(relief_run_with("auto", "tessellation", "", &in, 1, &out, &cb) == RELIEF_OK);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    relief_image_free(&out);
    INFO(seconds << " s, " << listens.progress.size() << " progress calls");
    if (seconds < 0.2)
        return;  // (a fast device may finish before a heartbeat is due)
    // at least one call for every 100 ms of the run, all of 0 but the last
    CHECK(double(listens.progress.size()) >= seconds / 0.1);
    CHECK(std::count(listens.progress.begin(), listens.progress.end(), 0.0) ==
          std::ptrdiff_t(listens.progress.size()) - 1);
    Host stops;
    stops.answer_at = 2;  // the first call after 0
    cb.user = &stops;
    CHECK(relief_run_with("auto", "tessellation", "", &in, 1, &out, &cb) == RELIEF_CANCELLED);
    const double after =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - stops.answered).count();
    CHECK(stops.progress == std::vector<double>{0.0, 0.0});
    CHECK(out.pixels == nullptr);
    // Stopped at the end of the part running, not of the pass: a wait on
    // the device hears the answer at once but lets the command in flight
    // finish (one launch: most of the run).
    INFO("returned " << after << " s after the answer");
    CHECK(after < 0.5 * seconds);
}

TEST_CASE("memory: an operation's estimate refuses a map before its input is copied", "[progress][memory]")
{
    test::ScopedEnv env("RELIEF_MEMORY_LIMIT", "64M");
    OperationCall height, slopes;
    REQUIRE(parse_modifiers(height, "height", "normal=opengl"));
    REQUIRE(parse_modifiers(slopes, "slopes", "normal=opengl"));
    // the height's slopes and integration grids (on any device: its result
    // alone, 256 MiB, is host memory)
    const std::string h = memory_problem(height, "auto", 8192, 8192);
    CHECK(h.rfind("height: ", 0) == 0);
    CHECK(h.find("the Poisson integration of a 8192x8192 map needs") != std::string::npos);
    CHECK(h.find("RELIEF_MEMORY_LIMIT=64M allows 64.0 MiB") != std::string::npos);
    OperationCall rays = height;
    REQUIRE(parse_modifiers(rays, "height", "normal=opengl:method=rays"));
    CHECK(memory_problem(rays, "auto", 8192, 8192).find("ray integration of a 8192x8192 map") !=
          std::string::npos);
    // every operation: its float result (slopes: 2 channels, 128 MiB here)
    CHECK(memory_problem(slopes, "auto", 4096, 4096) ==
          "slopes: the 4096x4096 result needs 128.0 MiB of memory, RELIEF_MEMORY_LIMIT=64M allows 64.0 MiB");
    CHECK(memory_problem(slopes, "auto", 64, 64).empty());
    CHECK(memory_problem(height, "auto", 64, 64).empty());
    // no device of that name: the estimate's own failure, said
    CHECK(memory_problem(height, "9:9", 64, 64).find("height: ") == 0);
}
