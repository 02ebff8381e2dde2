// SPDX-License-Identifier: Apache-2.0
// Skipping flat content (docs/design.md §6): a 4096^2 atlas that is 75% flat.
//
//   bench_skip [size=4096] [runs=3] [rays=32] [radius=64]
//
// Writes an 8-bit normal-map atlas: four bumpy islands covering a quarter of
// the area on a flat (128, 128, 255) background, then times whole `relief`
// processes of fast ray integration with skip=on and skip=off (warm PoCL
// cache), prints both medians and their ratio, and checks that the two
// outputs are bit-identical.
#include <OpenImageIO/imagebuf.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "image_files.h"
#include "run_process.h"

namespace fs = std::filesystem;

int main(int argc, char** argv)
{
    const int n = argc > 1 ? std::atoi(argv[1]) : 4096;
    const int runs = argc > 2 ? std::atoi(argv[2]) : 3;
    const int rays = argc > 3 ? std::atoi(argv[3]) : 32;
    const int radius = argc > 4 ? std::atoi(argv[4]) : 64;
    if (n < 64 || runs < 1) {
        std::fprintf(stderr, "usage: %s [size] [runs] [rays] [radius]\n", argv[0]);
        return 2;
    }
    const fs::path dir = "bench_skip.tmp";
    fs::create_directories(dir);
    // Four islands of (n/4)^2 each: a quarter of the area.
    std::vector<unsigned char> px(std::size_t(n) * n * 3);
    const int s = n / 4;
    const int corners[4][2] = {{n / 16, n / 16},
                               {n / 2 + n / 16, n / 16},
                               {n / 16, n / 2 + n / 16},
                               {n / 2 + n / 16, n / 2 + n / 16}};
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double gx = 0, gy = 0;
            for (const auto& c : corners)
                if (x >= c[0] && x < c[0] + s && y >= c[1] && y < c[1] + s) {
                    const double u = 2 * M_PI * (x - c[0]) / s, v = 2 * M_PI * (y - c[1]) / s;
                    gx = 0.6 * std::sin(3 * u) * std::sin(2 * v) + 0.2 * std::cos(17 * u + 5 * v);
                    gy = 0.5 * std::cos(4 * u) * std::sin(3 * v) + 0.2 * std::sin(13 * v - 3 * u);
                }
            const double len = std::sqrt(gx * gx + gy * gy + 1);
            unsigned char* p = &px[3 * (std::size_t(y) * n + x)];
            p[0] = (unsigned char)std::lround((-gx / len * 0.5 + 0.5) * 255);
            p[1] = (unsigned char)std::lround((gy / len * 0.5 + 0.5) * 255);
            p[2] = (unsigned char)std::lround((1 / len * 0.5 + 0.5) * 255);
            if (gx == 0 && gy == 0)
                p[0] = p[1] = 128, p[2] = 255;
        }
    const std::string normal = (dir / "atlas.png").string();
    bench::write_rgb(normal, n, OIIO::TypeDesc::UINT8, px);
    const std::string cache = "POCL_CACHE_DIR=" + (dir / "pocl-cache").string() + " ";
    std::vector<double> t[2];
    for (int skip : {1, 0}) {
        const std::string out = (dir / (skip ? "on.exr" : "off.exr")).string();
        const std::string cmd = cache + "'" + RELIEF_CLI + "' " + normal +
                                " --height:normal=opengl:boundary=clip:rays=" + std::to_string(rays) +
                                ":radius=" + std::to_string(radius) + ":skip=" + (skip ? "on" : "off") +
                                " -o " + out + " 2>/dev/null";
        bench::run_shell(cmd);  // warm the kernel cache
        for (int r = 0; r < runs; ++r)
            t[skip].push_back(bench::run_shell(cmd));
        std::sort(t[skip].begin(), t[skip].end());
    }
    const bool same =
        bench::read_channels((dir / "on.exr").string()) == bench::read_channels((dir / "off.exr").string());
    const double on = t[1][t[1].size() / 2], off = t[0][t[0].size() / 2];
    std::printf("| size | flat | rays | radius | runs | skip=off median s | skip=on median s | saved | "
                "identical |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    std::printf("| %d | 75%% | %d | %d | %d | %.2f | %.2f | %.0f%% | %s |\n", n, rays, radius, runs, off, on,
                100.0 * (1.0 - on / off), same ? "yes" : "NO");
    fs::remove_all(dir);
    return same ? 0 : 1;
}
