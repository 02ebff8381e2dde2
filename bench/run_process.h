// SPDX-License-Identifier: Apache-2.0
#pragma once
// Whole-process timing for the benchmarks that run relief (or a peer, or an
// older relief build) as a user would: fork, exec, wait; and the median.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace bench {

struct Timing {
    double wall = 0;    // seconds
    double rss_mb = 0;  // peak resident set of the process
};

// Runs argv with stdout to /dev/null and stderr to `log` (or /dev/null),
// POCL_CACHE_DIR and RELIEF_CACHE_DIR set under `cache_root` (warm caches,
// as a farm node's after its first map, once one run has filled them);
// returns the wall time and peak memory, or exits naming the command when
// it fails.
inline Timing run_measured(const std::vector<std::string>& argv, const std::string& cache_root,
                           const std::string& log = "")
{
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = fork();
    if (pid == 0) {
        setenv("POCL_CACHE_DIR", (cache_root + "/pocl-cache").c_str(), 1);
        setenv("RELIEF_CACHE_DIR", (cache_root + "/relief-cache").c_str(), 1);
        const std::string to = log.empty() ? "/dev/null" : log;
        if (!std::freopen(to.c_str(), "w", stderr) || !std::freopen("/dev/null", "w", stdout))
            _exit(127);
        std::vector<char*> a;
        for (const auto& s : argv)
            a.push_back(const_cast<char*>(s.c_str()));
        a.push_back(nullptr);
        execv(a[0], a.data());
        _exit(127);
    }
    int status = 0;
    struct rusage ru {};
    wait4(pid, &status, 0, &ru);
    Timing t;
    t.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t.rss_mb = ru.ru_maxrss / 1024.0;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        std::string cmd;
        for (const auto& s : argv)
            cmd += s + " ";
        std::fprintf(stderr, "bench: command failed (status %d): %s\n", status, cmd.c_str());
        std::exit(1);
    }
    return t;
}

inline double run_process(const std::vector<std::string>& argv, const std::string& cache_root,
                          const std::string& log = "")
{
    return run_measured(argv, cache_root, log).wall;
}

// A shell command line (environment assignments in front, as a user types
// them): the wall seconds, or exits naming it when it fails.
inline double run_shell(const std::string& cmd)
{
    const auto t0 = std::chrono::steady_clock::now();
    const int status = std::system(cmd.c_str());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        std::fprintf(stderr, "bench: command failed: %s\n", cmd.c_str());
        std::exit(1);
    }
    return s;
}

inline double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace bench
