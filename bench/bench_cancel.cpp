// SPDX-License-Identifier: Apache-2.0
// How soon a cancel stops a long operation: a host's progress callback
// (C ABI, relief_run_with) answers "stop" after a set time into a 1024^2
// correction of a steep field (columns of cliffs, default modifiers but
// scale=0.05), and the time from that answer to relief_run_with's return
// is measured. Runs --runs times, the cancel later each time, and prints
// each run and the median.
//
// Usage: bench_cancel [--size N] [--runs K] [--after SECONDS]
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
    Clock::time_point start, asked;
    double after = 0.0;
    bool cancelled = false;
    int calls = 0;
};

int progress(double, void* user)
{
    auto* w = static_cast<Watch*>(user);
    ++w->calls;
    if (!w->cancelled && std::chrono::duration<double>(Clock::now() - w->start).count() >= w->after) {
        w->cancelled = true;
        w->asked = Clock::now();
        return 1;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv)
{
    int n = 1024, runs = 5;
    double after = 2.0;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!std::strcmp(argv[i], "--size"))
            n = std::atoi(argv[i + 1]);
        else if (!std::strcmp(argv[i], "--runs"))
            runs = std::atoi(argv[i + 1]);
        else if (!std::strcmp(argv[i], "--after"))
            after = std::atof(argv[i + 1]);
        else {
            std::fprintf(stderr, "bench_cancel: unknown argument %s\n", argv[i]);
            return 2;
        }
    }
    std::vector<float> h(std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            h[std::size_t(y) * n + x] = float((x / 64) % 2) + 0.3f * std::sin(y * 0.05f);
    relief_image in = {n, n, 1, RELIEF_FLOAT, h.data(), nullptr};
    std::vector<double> stops;
    for (int k = 0; k < runs; ++k) {
        Watch w;
        w.after = after * (1.0 + 0.15 * k);
        w.start = Clock::now();
        relief_callbacks cb = {nullptr, progress, &w};
        relief_image out{};
        const int status = relief_run_with("auto", "correct", "scale=0.05", &in, 1, &out, &cb);
        const auto end = Clock::now();
        if (status != RELIEF_CANCELLED) {
            std::fprintf(stderr, "bench_cancel: the correction ended (status %d) before %.2f s: %s\n", status,
                         w.after, relief_last_error());
            relief_image_free(&out);
            return 1;
        }
        const double stop = std::chrono::duration<double>(end - w.asked).count();
        stops.push_back(stop);
        std::printf(
            "%dx%d correction, cancel answered at %.2f s (progress call %d): returned %.1f ms later\n", n, n,
            std::chrono::duration<double>(w.asked - w.start).count(), w.calls, stop * 1e3);
    }
    std::sort(stops.begin(), stops.end());
    std::printf("median: %.1f ms from the cancel to the return (%d runs)\n", stops[stops.size() / 2] * 1e3,
                runs);
    return 0;
}
