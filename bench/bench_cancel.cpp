// SPDX-License-Identifier: Apache-2.0
// How often an operation reports progress, and how soon a cancel stops it,
// through the C ABI (relief_run_with) on a 1024^2 map. Each operation runs
// once to the end, its progress calls timed (the longest gap between two,
// or between the last and the return, and the fraction it started from),
// then --runs times with a host that wants to stop at a set share of that
// whole time: as a host's other thread would, it sets a flag then, and its
// progress callback answers with the flag. The cancel's latency is the
// time from the flag to the return (so it counts the wait for the next
// progress call as well as the stop). Prints a table, one row per
// operation, with the median and worst latency.
//
// Usage: bench_cancel [--size N] [--runs K] [--only OPERATION]
//   (OPERATION as the table's first column: "correct", "height rays", ...)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "relief/relief_c.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Watch {
    Clock::time_point start, last;
    double after = -1.0;  // seconds into the run when the host wants to stop; < 0: never
    bool answered = false;
    int calls = 0;
    double longest_gap = 0.0, gap_from = 0.0, fraction = 0.0;
};

int progress(double fraction, void* user)
{
    auto* w = static_cast<Watch*>(user);
    const Clock::time_point now = Clock::now();
    const double gap = std::chrono::duration<double>(now - w->last).count();
    if (gap > w->longest_gap) {
        w->longest_gap = gap;
        w->gap_from = w->fraction;
    }
    w->last = now;
    w->fraction = fraction;
    ++w->calls;
    // The flag a host's other thread would have set at `after`.
    if (w->after >= 0.0 && std::chrono::duration<double>(now - w->start).count() >= w->after) {
        w->answered = true;
        return 1;
    }
    return 0;
}

struct Case {
    const char* name;
    const char* operation;
    std::string modifiers;
    std::vector<const relief_image*> inputs;
};

}  // namespace

int main(int argc, char** argv)
{
    int n = 1024, runs = 5;
    std::string only;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!std::strcmp(argv[i], "--size"))
            n = std::atoi(argv[i + 1]);
        else if (!std::strcmp(argv[i], "--runs"))
            runs = std::atoi(argv[i + 1]);
        else if (!std::strcmp(argv[i], "--only"))
            only = argv[i + 1];
        else {
            std::fprintf(stderr, "bench_cancel: unknown argument %s\n", argv[i]);
            return 2;
        }
    }
    // A steep height (columns of cliffs) and its normals (OpenGL, float).
    std::vector<float> h(std::size_t(n) * n), normals(3 * std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            h[std::size_t(y) * n + x] =
                float((x / 64) % 2) * 8.0f + 3.0f * std::sin(y * 0.05f) * std::cos(x * 0.03f);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const auto at = [&](int xx, int yy) {
                return h[std::size_t((yy + n) % n) * n + std::size_t((xx + n) % n)];
            };
            const float gx = 0.5f * (at(x + 1, y) - at(x - 1, y)), gy = 0.5f * (at(x, y + 1) - at(x, y - 1));
            const float len = std::sqrt(gx * gx + gy * gy + 1.0f);
            float* p = &normals[3 * (std::size_t(y) * n + x)];
            p[0] = -gx / len;
            p[1] = gy / len;  // OpenGL: y up
            p[2] = 1.0f / len;
        }
    // A texture (RGB float) and small offsets (u, v in texture units) for the bake.
    std::vector<float> texture(3 * std::size_t(n) * n), offsets(2 * std::size_t(n) * n);
    for (std::size_t i = 0; i < std::size_t(n) * n; ++i) {
        const float x = float(i % std::size_t(n)), y = float(i / std::size_t(n));
        texture[3 * i] = 0.5f + 0.5f * std::sin(0.1f * x);
        texture[3 * i + 1] = 0.5f + 0.5f * std::cos(0.07f * y);
        texture[3 * i + 2] = 0.5f;
        offsets[2 * i] = 0.002f * std::sin(0.02f * y);
        offsets[2 * i + 1] = 0.002f * std::cos(0.03f * x);
    }
    const relief_image in_h = {n, n, 1, RELIEF_FLOAT, h.data(), nullptr};
    const relief_image in_n = {n, n, 3, RELIEF_FLOAT, normals.data(), nullptr};
    const relief_image in_t = {n, n, 3, RELIEF_FLOAT, texture.data(), nullptr};
    const relief_image in_o = {n, n, 2, RELIEF_FLOAT, offsets.data(), nullptr};
    const std::string mesh_file =
        (std::filesystem::temp_directory_path() / ("bench_cancel_" + std::to_string(n) + ".glb")).string();
    const Case cases[] = {
        {"slopes", "slopes", "normal=opengl", {&in_n}},
        {"height least squares", "height", "normal=opengl", {&in_n}},
        {"height rays", "height", "normal=opengl:method=rays", {&in_n}},
        {"height rays clip", "height", "normal=opengl:method=rays:boundary=clip", {&in_n}},
        {"height rays reference",
         "height",
         "normal=opengl:method=rays:impl=reference:rays=16:radius=64",
         {&in_n}},
        {"correct", "correct", "scale=0.05", {&in_h}},
        {"correct corner", "correct", "scale=0.05:nodes=corner", {&in_h}},
        {"bake", "bake", "", {&in_t, &in_o}},
        {"normals", "normals", "", {&in_h}},
        {"tessellation", "tessellation", "", {&in_h}},
        {"mesh", "mesh", "patch=16:error=0.25:out=" + mesh_file, {&in_h}},
        {"preview", "preview", "normal=opengl", {&in_n, &in_h}},
    };
    std::printf("%dx%d, through relief_run_with; times in ms\n", n, n);
    std::printf(
        "| operation | run | progress calls | longest gap (from fraction) | cancel latency, median of %d "
        "| worst |\n",
        runs);
    std::printf("|---|---|---|---|---|---|\n");
    for (const Case& c : cases) {
        if (!only.empty() && only != c.name)
            continue;
        std::vector<relief_image> in;
        for (const relief_image* i : c.inputs)
            in.push_back(*i);
        const int count = int(in.size());
        const char* mods = c.modifiers.c_str();
        relief_image out{};
        // (a first run sets up the device, kernels and plans: not timed)
        if (relief_run_on("auto", c.operation, mods, in.data(), count, &out) == RELIEF_OK)
            relief_image_free(&out);
        Watch whole;
        whole.start = whole.last = Clock::now();
        relief_callbacks cb = {nullptr, progress, &whole};
        int status = relief_run_with("auto", c.operation, mods, in.data(), count, &out, &cb);
        const Clock::time_point end = Clock::now();
        relief_image_free(&out);
        if (status != RELIEF_OK) {
            std::fprintf(stderr, "bench_cancel: %s failed: %s\n", c.name, relief_last_error());
            return 1;
        }
        const double total = std::chrono::duration<double>(end - whole.start).count();
        const double tail = std::chrono::duration<double>(end - whole.last).count();
        if (tail > whole.longest_gap) {
            whole.longest_gap = tail;
            whole.gap_from = whole.fraction;
        }
        std::vector<double> stops;
        for (int k = 0; k < runs; ++k) {
            Watch w;
            w.after = total * (0.2 + 0.6 * (k + 0.5) / runs);
            w.start = w.last = Clock::now();
            relief_callbacks stop = {nullptr, progress, &w};
            status = relief_run_with("auto", c.operation, mods, in.data(), count, &out, &stop);
            const Clock::time_point e = Clock::now();
            relief_image_free(&out);
            if (w.answered && status != RELIEF_CANCELLED)
                std::fprintf(stderr, "bench_cancel: %s: answered in run %d, which returned %d\n", c.name, k,
                             status);
            const Clock::time_point wanted =
                w.start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(w.after));
            stops.push_back(std::chrono::duration<double>(e - wanted).count());
        }
        std::sort(stops.begin(), stops.end());
        std::printf("| %s | %.0f | %d | %.0f (%.2f) | %.0f | %.0f |\n", c.name, total * 1e3, whole.calls,
                    whole.longest_gap * 1e3, whole.gap_from, stops[stops.size() / 2] * 1e3,
                    stops.back() * 1e3);
        std::fflush(stdout);
    }
    std::filesystem::remove(mesh_file);
    return 0;
}
