// SPDX-License-Identifier: Apache-2.0
// Peak memory of whole relief processes on large tiling maps: the resident
// set at its peak, per texel, for least squares and rays, both boundaries.
// Usage: bench_memory [--sizes 4096,8192,16384] [--out DIR]
// Writes DIR/memory.md and DIR/memory.csv (default bench/results).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "support/large_maps.h"

namespace fs = std::filesystem;

int main(int argc, char** argv)
{
    std::vector<int> sizes{4096, 8192, 16384};
    std::string out_dir = std::string(RELIEF_SOURCE_DIR) + "/bench/results";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--sizes" && i + 1 < argc) {
            sizes.clear();
            std::stringstream list(argv[++i]);
            for (std::string s; std::getline(list, s, ',');)
                sizes.push_back(std::atoi(s.c_str()));
        } else if (a == "--out" && i + 1 < argc) {
            out_dir = argv[++i];
        } else {
            std::fprintf(stderr, "usage: bench_memory [--sizes 4096,8192,16384] [--out DIR]\n");
            return 2;
        }
    }
    const fs::path work = fs::temp_directory_path() / ("relief-bench-memory-" + std::to_string(::getpid()));
    fs::create_directories(work);
    const int tile = 2048;
    const std::vector<std::uint8_t> tile_px = relief::test::tiling_normal_tile(tile);
    const char* commands[] = {"--height", "--height:boundary=free", "--height:method=rays:radius=16",
                              "--height:method=rays:radius=16:boundary=clip"};
    const std::string cli = "'" + std::string(RELIEF_CLI) + "' ";

    // The process's own share: a 64 x 64 map.
    double base = 0;
    {
        const std::string small = (work / "small.tif").string();
        std::vector<std::uint8_t> px(64 * 64 * 3);
        for (int y = 0; y < 64; ++y)
            std::copy_n(&tile_px[std::size_t(y) * tile * 3], 64 * 3, &px[std::size_t(y) * 64 * 3]);
        relief::test::write_tiled_map(small, px, 64, 1);
        relief::test::run_measured(cli + "'" + small + "' --height -o '" + (work / "s.exr").string() + "'",
                                   base);
    }
    std::ostringstream md, csv;
    csv << "size,command,peak_rss_bytes,bytes_per_texel,seconds,exit\n";
    md << "# Peak memory per texel, whole process\n\n"
       << "`bench_memory`: `relief MAP.tif COMMAND -o h.exr` on an 8-bit RGB tiling map (an uncompressed "
          "TIFF of 2048^2 tiles), peak resident set of the process (wait4's ru_maxrss) over the map's "
          "texels. "
          "A 64^2 map peaks at "
       << relief::test::format_gb(base) << " (PoCL, LLVM and the libraries).\n\n"
       << "| size | command | peak RSS | bytes per texel | seconds |\n|---|---|---|---|---|\n";
    for (int n : sizes) {
        const std::string map = (work / "map.tif").string();
        if (!relief::test::write_tiled_map(map, tile_px, std::min(tile, n), std::max(1, n / tile))) {
            std::fprintf(stderr, "bench_memory: cannot write %s\n", map.c_str());
            return 1;
        }
        for (const char* c : commands) {
            double peak = 0;
            const auto t0 = std::chrono::steady_clock::now();
            const int rc = relief::test::run_measured(
                cli + "'" + map + "' " + c + " -o '" + (work / "h.exr").string() + "'", peak);
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const double per = peak / (double(n) * n);
            std::printf("%d^2 %-46s peak %s  %.2f B/texel  %.1f s  exit %d\n", n, c,
                        relief::test::format_gb(peak).c_str(), per, s, rc);
            std::fflush(stdout);
            csv << n << "," << c << "," << std::int64_t(peak) << "," << per << "," << s << "," << rc << "\n";
            char row[256];
            std::snprintf(row, sizeof row, "| %d² | `%s` | %s | %.2f | %.1f |\n", n, c,
                          relief::test::format_gb(peak).c_str(), per, s);
            md << row;
            fs::remove(work / "h.exr");
        }
        fs::remove(map);
    }
    fs::remove_all(work);
    fs::create_directories(out_dir);
    std::ofstream(fs::path(out_dir) / "memory.md") << md.str();
    std::ofstream(fs::path(out_dir) / "memory.csv") << csv.str();
    return 0;
}
