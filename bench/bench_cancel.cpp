// SPDX-License-Identifier: Apache-2.0
// How often an operation reports progress, and how soon a cancel stops it,
// through the C ABI (relief_run_with) on a 1024^2 map: each operation runs
// once to the end, its progress calls timed (the longest gap between two,
// and between the last and the return), then --runs times with a host's
// progress callback that answers "stop" once a set share of that whole
// time has passed; the time from that answer to the return is the cancel's
// latency. Prints a table, one row per operation, with the median latency.
//
// Usage: bench_cancel [--size N] [--runs K] [--only OPERATION]
//   (OPERATION as the table's first column: "correct", "height rays", ...)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "relief/relief_c.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Watch {
    Clock::time_point start, asked, last;
    double after = -1.0;  // seconds into the run to answer "stop"; < 0: never
    bool cancelled = false;
    int calls = 0;
    double longest_gap = 0.0;
};

int progress(double, void* user)
{
    auto* w = static_cast<Watch*>(user);
    const Clock::time_point now = Clock::now();
    w->longest_gap = std::max(w->longest_gap, std::chrono::duration<double>(now - w->last).count());
    w->last = now;
    ++w->calls;
    if (w->after >= 0.0 && !w->cancelled &&
        std::chrono::duration<double>(now - w->start).count() >= w->after) {
        w->cancelled = true;
        w->asked = now;
        return 1;
    }
    return 0;
}

struct Case {
    const char* name;
    const char* operation;
    const char* modifiers;
    bool takes_height;  // else normals
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
    const relief_image in_h = {n, n, 1, RELIEF_FLOAT, h.data(), nullptr};
    const relief_image in_n = {n, n, 3, RELIEF_FLOAT, normals.data(), nullptr};
    const Case cases[] = {
        {"slopes", "slopes", "normal=opengl", false},
        {"height least squares", "height", "normal=opengl", false},
        {"height rays", "height", "normal=opengl:method=rays", false},
        {"height rays clip", "height", "normal=opengl:method=rays:boundary=clip", false},
        {"height rays reference", "height", "normal=opengl:method=rays:impl=reference:rays=16:radius=64",
         false},
        {"correct", "correct", "scale=0.05", true},
        {"normals", "normals", "", true},
        {"tessellation", "tessellation", "", true},
    };
    std::printf("%dx%d, through relief_run_with; times in ms\n", n, n);
    std::printf("| operation | run | progress calls | longest gap | cancel latency, median of %d | worst |\n",
                runs);
    std::printf("|---|---|---|---|---|---|\n");
    for (const Case& c : cases) {
        if (!only.empty() && only != c.name)
            continue;
        const relief_image* in = c.takes_height ? &in_h : &in_n;
        const std::string mods = c.modifiers;
        relief_image out{};
        // (a first run sets up the device, kernels and plans: not timed)
        if (relief_run_on("auto", c.operation, mods.c_str(), in, 1, &out) == RELIEF_OK)
            relief_image_free(&out);
        Watch whole;
        whole.start = whole.last = Clock::now();
        relief_callbacks cb = {nullptr, progress, &whole};
        int status = relief_run_with("auto", c.operation, mods.c_str(), in, 1, &out, &cb);
        const Clock::time_point end = Clock::now();
        relief_image_free(&out);
        if (status != RELIEF_OK) {
            std::fprintf(stderr, "bench_cancel: %s failed: %s\n", c.name, relief_last_error());
            return 1;
        }
        const double total = std::chrono::duration<double>(end - whole.start).count();
        const double gap =
            std::max(whole.longest_gap, std::chrono::duration<double>(end - whole.last).count());
        std::vector<double> stops;
        for (int k = 0; k < runs; ++k) {
            Watch w;
            w.after = total * (0.2 + 0.6 * (k + 0.5) / runs);
            w.start = w.last = Clock::now();
            relief_callbacks stop = {nullptr, progress, &w};
            status = relief_run_with("auto", c.operation, mods.c_str(), in, 1, &out, &stop);
            const Clock::time_point e = Clock::now();
            relief_image_free(&out);
            // A run whose progress came too seldom to be asked ends OK: its
            // latency is the time left after the moment to stop.
            const Clock::time_point asked = w.cancelled
                                                ? w.asked
                                                : w.start + std::chrono::duration_cast<Clock::duration>(
                                                                std::chrono::duration<double>(w.after));
            stops.push_back(std::chrono::duration<double>(e - asked).count());
        }
        std::sort(stops.begin(), stops.end());
        std::printf("| %s | %.0f | %d | %.0f | %.0f | %.0f |\n", c.name, total * 1e3, whole.calls, gap * 1e3,
                    stops[stops.size() / 2] * 1e3, stops.back() * 1e3);
        std::fflush(stdout);
    }
    return 0;
}
