// SPDX-License-Identifier: Apache-2.0
#pragma once
// Large tiling normal maps for the memory tests and bench_memory: one
// periodic tile, written repeated without ever holding the large map, and
// the peak resident memory of a child process that integrates it.
#include <OpenImageIO/imageio.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace relief::test {

// A tile x tile 8-bit RGB (OpenGL) normal map of a smooth periodic height:
// a sum of sinusoids of whole periods across the tile, so that the map tiles.
inline std::vector<std::uint8_t> tiling_normal_tile(int tile, unsigned seed = 5)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
    struct Wave {
        int fx, fy;
        double a, p;
    };
    std::vector<Wave> waves;
    for (int k = 1; k <= 24; ++k)
        waves.push_back({int(rng() % 17) - 8, int(rng() % 17) - 8, 3.0 / k, phase(rng)});
    std::vector<std::uint8_t> px(std::size_t(tile) * tile * 3);
    const double w = 2.0 * M_PI / tile;
    for (int y = 0; y < tile; ++y)
        for (int x = 0; x < tile; ++x) {
            double gx = 0, gy = 0;  // slopes of h = sum a sin(w (fx x + fy y) + p)
            for (const Wave& v : waves) {
                const double c = v.a * w * std::cos(w * (v.fx * x + v.fy * y) + v.p) * 40.0;
                gx += c * v.fx;
                gy += c * v.fy;
            }
            const double len = std::sqrt(gx * gx + gy * gy + 1.0);
            const double n[3] = {-gx / len, gy / len, 1.0 / len};  // OpenGL: green = -dh/dy
            for (int c = 0; c < 3; ++c)
                px[3 * (std::size_t(y) * tile + x) + c] =
                    std::uint8_t(std::lround((n[c] + 1.0) * 0.5 * 255.0));
        }
    return px;
}

// Writes `tile` (tile x tile RGB bytes) repeated `repeats` times each way as
// an uncompressed 8-bit TIFF, a scanline at a time. Returns false on failure.
inline bool write_tiled_map(const std::string& path, const std::vector<std::uint8_t>& tile_px, int tile,
                            int repeats)
{
    const int n = tile * repeats;
    auto out = OIIO::ImageOutput::create(path);
    if (!out)
        return false;
    OIIO::ImageSpec spec(n, n, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("compression", "none");
    if (!out->open(path, spec))
        return false;
    std::vector<std::uint8_t> row(std::size_t(n) * 3);
    for (int y = 0; y < n; ++y) {
        const std::uint8_t* src = &tile_px[std::size_t(y % tile) * tile * 3];
        for (int r = 0; r < repeats; ++r)
            std::copy(src, src + std::size_t(tile) * 3, row.begin() + std::size_t(r) * tile * 3);
        if (!out->write_scanline(y, 0, OIIO::TypeDesc::UINT8, row.data()))
            return false;
    }
    return out->close();
}

// "1.23 GB"
inline std::string format_gb(double bytes)
{
    char text[32];
    std::snprintf(text, sizeof text, "%.2f GB", bytes / 1e9);
    return text;
}

// Runs `command` (sh -c) in a child and returns its exit code; `peak_bytes`
// gets the child's peak resident memory (the largest of it and its own
// children that were waited for).
inline int run_measured(const std::string& command, double& peak_bytes)
{
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    int status = 0;
    struct rusage use {};
    if (pid < 0 || ::wait4(pid, &status, 0, &use) != pid)
        return -1;
    peak_bytes = double(use.ru_maxrss) * 1024.0;  // kilobytes on Linux
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace relief::test
