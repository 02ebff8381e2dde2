// SPDX-License-Identifier: Apache-2.0
// What --update's completeness check costs on an all-skipped batch (issue
// 25): every output's digest is read from its header, and then its last
// scanline (a PNG's closing chunk) so that a truncated file is recomputed.
//
//   bench_update [--jobs 60] [--runs 7] [--relief PATH] [--baseline PATH] [--out DIR]
//
// Makes --jobs jobs over the bundled 512^2 maps, each writing its slopes
// as a float OpenEXR, a 16-bit PNG and a 16-bit TIFF (untimed first batch), then times --runs all-skipped `--batch --update` runs of
// PATH (default: this build's relief) and, alternating with them, of
// --baseline (an older relief build without the check, when given: the same
// digests, so it skips the same jobs). Prints medians and their ratio.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "run_process.h"

namespace fs = std::filesystem;

int main(int argc, char** argv)
{
    int jobs = 60, runs = 7;
    std::string relief = RELIEF_CLI, baseline, out = "bench-update";
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string a = argv[i], v = argv[i + 1];
        if (a == "--jobs")
            jobs = std::stoi(v);
        else if (a == "--runs")
            runs = std::stoi(v);
        else if (a == "--relief")
            relief = v;
        else if (a == "--baseline")
            baseline = v;
        else if (a == "--out")
            out = v;
        else {
            std::fprintf(stderr,
                         "usage: %s [--jobs N] [--runs N] [--relief PATH] [--baseline PATH] [--out DIR]\n",
                         argv[0]);
            return 2;
        }
    }
    const fs::path dir = fs::absolute(out);
    fs::create_directories(dir / "maps");
    const std::vector<std::string> maps = {std::string(RELIEF_DATA) + "/gk_metal_tech_01/normal.png",
                                           std::string(RELIEF_DATA) + "/dem_jacksboro/normal.png"};
    {
        std::ofstream m(dir / "jobs.txt");
        for (int j = 0; j < jobs; ++j)
            m << "'" << maps[j % 2] << "' --slopes -o maps/s" << j << ".exr -d uint16 -o maps/s" << j
              << ".png -o maps/s" << j << ".tif\n";
    }
    const std::string manifest = (dir / "jobs.txt").string();
    fs::current_path(dir);
    bench::run_process({relief, "--batch", manifest}, dir.string());
    std::vector<double> ours, theirs;
    for (int r = 0; r < runs; ++r) {
        ours.push_back(bench::run_process({relief, "--batch", manifest, "--update"}, dir.string()));
        if (!baseline.empty())
            theirs.push_back(bench::run_process({baseline, "--batch", manifest, "--update"}, dir.string()));
    }
    const double a = bench::median(ours);
    std::printf(
        "all-skipped --update over %d jobs (%d outputs): median of %d runs %.3f s (%.2f ms per job)\n", jobs,
        3 * jobs, runs, a, 1e3 * a / jobs);
    if (!baseline.empty()) {
        const double b = bench::median(theirs);
        std::printf("baseline %s: %.3f s (%.2f ms per job); with the check / without: %.2f\n",
                    baseline.c_str(), b, 1e3 * b / jobs, a / b);
    }
    return 0;
}
