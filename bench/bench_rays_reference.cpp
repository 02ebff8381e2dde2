// SPDX-License-Identifier: Apache-2.0
// Whole-process run time of the reference ray integration, and its error
// against analytic truth, on a synthetic normal map.
//
//   bench_rays_reference [size=1024] [rays=32] [radius=64] [runs=5]
//
// Writes a size x size float normal map of a smooth periodic field, runs
// `relief N.exr --height:impl=reference:... -o H.exr` once to warm the PoCL
// kernel cache (reported as "cold"), then `runs` times, and prints the median,
// min and max wall time and the RMS error of the result against the exact
// h - mean_disk_R(h) as a fraction of its standard deviation.
#include <OpenImageIO/imagebuf.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "image_files.h"
#include "run_process.h"

namespace {

struct Wave {
    int kx, ky;
    double a, phase;
};
const Wave kWaves[] = {{1, 0, 8.0, 0.2}, {2, 3, 3.0, 1.0}, {-5, 2, 1.5, 2.5}, {9, 7, 0.6, 0.4}};

}  // namespace

int main(int argc, char** argv)
{
    const int n = argc > 1 ? std::atoi(argv[1]) : 1024;
    const int rays = argc > 2 ? std::atoi(argv[2]) : 32;
    const double radius = argc > 3 ? std::atof(argv[3]) : 64.0;
    const int runs = argc > 4 ? std::atoi(argv[4]) : 5;
    if (n < 8 || rays < 1 || radius <= 0 || runs < 1) {
        std::fprintf(stderr, "usage: %s [size] [rays] [radius] [runs]\n", argv[0]);
        return 2;
    }

    // Float RGB normals (OpenGL) of the field, and the exact target.
    std::vector<float> px(std::size_t(n) * n * 3);
    std::vector<double> truth(std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double gx = 0, gy = 0, t = 0;
            for (const Wave& w : kWaves) {
                double arg = 2 * M_PI * (w.kx * double(x) + w.ky * double(y)) / n + w.phase;
                double k = 2 * M_PI * std::hypot(w.kx, w.ky) / n;
                gx -= w.a * std::sin(arg) * 2 * M_PI * w.kx / n;
                gy -= w.a * std::sin(arg) * 2 * M_PI * w.ky / n;
                t += w.a * std::cos(arg) * (1.0 - 2.0 * std::cyl_bessel_j(1.0, k * radius) / (k * radius));
            }
            double len = std::sqrt(gx * gx + gy * gy + 1);
            std::size_t i = std::size_t(y) * n + x;
            px[3 * i] = float(-gx / len);
            px[3 * i + 1] = float(gy / len);  // OpenGL: G' = -n_row = gy / len
            px[3 * i + 2] = float(1 / len);
            truth[i] = t;
        }
    const std::string dir = "bench_rays_reference.tmp";
    std::system(("mkdir -p " + dir).c_str());
    const std::string normal = dir + "/normal.exr", height = dir + "/height.exr";
    bench::write_rgb(normal, n, OIIO::TypeDesc::FLOAT, px);

    char mods[160];
    std::snprintf(mods, sizeof mods, "--height:method=rays:impl=reference:normal=opengl:rays=%d:radius=%g",
                  rays, radius);
    const std::string cmd = std::string("'") + RELIEF_CLI + "' " + normal + " " + mods + " -o " + height;
    const std::string cache = dir + "/pocl-cache";
    std::system(("rm -rf " + cache).c_str());
    const double cold = bench::run_shell("POCL_CACHE_DIR=" + cache + " " + cmd);
    std::vector<double> t;
    for (int i = 0; i < runs; ++i)
        t.push_back(bench::run_shell("POCL_CACHE_DIR=" + cache + " " + cmd));
    std::sort(t.begin(), t.end());

    const std::vector<float> h = bench::read_channels(height);
    double se = 0, st = 0;
    for (std::size_t i = 0; i < h.size(); ++i) {
        se += (h[i] - truth[i]) * (h[i] - truth[i]);
        st += truth[i] * truth[i];
    }
    std::printf("| size | rays | radius | runs | cold s | median s | min s | max s | RMS error / std |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    std::printf("| %d | %d | %g | %d | %.3f | %.3f | %.3f | %.3f | %.2e |\n", n, rays, radius, runs, cold,
                t[t.size() / 2], t.front(), t.back(), std::sqrt(se / st));
    std::system(("rm -rf " + dir).c_str());
    return 0;
}
