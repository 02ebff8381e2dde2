// SPDX-License-Identifier: Apache-2.0
// A texture farm's view of relief (issue 12): whole processes, real maps,
// against a peer run once per file.
//
//   bench_farm --peer PATH [--data DIR] [--runs 5] [--out bench-results]
//
// PATH is Polzer's FFT normal-to-height tool (fft-normalmap-to-heightmap,
// GPL, from the Xonotic repository's misc/tools), built outside relief:
//   gcc -O2 -std=c99 fft-normalmap-to-heightmap.c -lfftw3 -lm
// and run as `PATH in.tga out.tga none` (it reads and writes Targa only;
// relief reads the same pixels as 8-bit PNG). From DIR (../shared/data) the
// bench cuts >= 25 maps of 512^2 and >= 6 of 1024^2 (untimed), then times,
// in one run:
//   - throughput: the peer once per file; `relief --batch` over the same
//     files (default --height); relief once per file; every batch output
//     must equal its single-map run (<= 1e-6 of std);
//   - an all-skipped `--update` rerun of the batch, against the first run;
//   - single maps at 512^2, 1024^2, 2048^2: peer and relief alternating,
//     --runs times each, medians;
//   - each size on its own (>= 25 maps of 512^2, >= 6 of 1024^2): the peer
//     per file against `relief --batch`, alternating, --runs times, medians;
//   - the per-map split of a batch (`relief -v --batch`: each job's read,
//     --height and write, medians) and how much of its file work overlapped
//     the device's;
//   - the per-map overhead split that `relief -v` reports.
// relief runs with warm caches (POCL_CACHE_DIR and RELIEF_CACHE_DIR under
// --out, filled by one untimed run first), as a farm's nodes would after
// their first map. Writes farm.md and farm.csv into --out.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "image_files.h"
#include "run_process.h"

namespace fs = std::filesystem;

namespace {

std::string g_out;

double run(const std::vector<std::string>& argv, const std::string& log = "")
{
    return bench::run_process(argv, g_out, log);
}

using bench::median;

struct Map {
    std::string name, png, tga;
    int size;
};

// size x size crops of the data set's normal maps, as 8-bit RGB PNG and TGA.
std::vector<Map> cut_maps(const std::string& data, int size, int wanted, const std::string& dir)
{
    std::vector<Map> maps;
    std::vector<fs::path> sets;
    for (const auto& e : fs::directory_iterator(data))
        if (fs::exists(e.path() / "normal.png"))
            sets.push_back(e.path());
    std::sort(sets.begin(), sets.end());
    // crops from every set in turn, so the maps are as varied as the data allows
    for (int round = 0; int(maps.size()) < wanted && round < 64; ++round)
        for (const fs::path& set : sets) {
            if (int(maps.size()) >= wanted)
                break;
            OIIO::ImageBuf src((set / "normal.png").string());
            const int w = src.spec().width, h = src.spec().height;
            const int across = w / size, down = h / size;
            if (round >= across * down)
                continue;
            const int x = (round % across) * size, y = (round / across) * size;
            OIIO::ImageBuf rgb = OIIO::ImageBufAlgo::channels(src, 3, {0, 1, 2});
            OIIO::ImageBuf crop = OIIO::ImageBufAlgo::cut(rgb, OIIO::ROI(x, x + size, y, y + size));
            Map m;
            m.name = set.filename().string() + "_" + std::to_string(size) + "_" + std::to_string(round);
            m.png = dir + "/" + m.name + ".png";
            m.tga = dir + "/" + m.name + ".tga";
            m.size = size;
            crop.set_write_format(OIIO::TypeDesc::UINT8);
            if (!crop.write(m.png) || !crop.write(m.tga)) {
                std::fprintf(stderr, "bench_farm: cannot write %s\n", m.png.c_str());
                std::exit(1);
            }
            maps.push_back(m);
        }
    return maps;
}

}  // namespace

int main(int argc, char** argv)
{
    std::string peer, data = RELIEF_SHARED_DATA, out = "bench-results";
    int runs = 5;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--peer" && i + 1 < argc)
            peer = argv[++i];
        else if (a == "--data" && i + 1 < argc)
            data = argv[++i];
        else if (a == "--runs" && i + 1 < argc)
            runs = std::max(1, std::atoi(argv[++i]));
        else if (a == "--out" && i + 1 < argc)
            out = argv[++i];
        else {
            std::fprintf(stderr, "usage: bench_farm --peer PATH [--data DIR] [--runs N] [--out DIR]\n");
            return 2;
        }
    }
    if (peer.empty() || access(peer.c_str(), X_OK) != 0) {
        std::fprintf(stderr,
                     "bench_farm: --peer PATH must name the built peer (see the comment at the top)\n");
        return 2;
    }
    if (!fs::is_directory(data)) {
        std::fprintf(stderr, "bench_farm: no data folder %s\n", data.c_str());
        return 2;
    }
    fs::create_directories(out);
    g_out = fs::absolute(out).string();
    const std::string relief = RELIEF_CLI;
    const std::string work = g_out + "/farm";
    fs::remove_all(work);
    fs::create_directories(work + "/maps");
    fs::create_directories(work + "/out");

    std::vector<Map> maps = cut_maps(data, 512, 28, work + "/maps");
    const std::vector<Map> big = cut_maps(data, 1024, 8, work + "/maps");
    maps.insert(maps.end(), big.begin(), big.end());
    std::fprintf(stderr, "bench_farm: %zu maps (%zu of 1024^2)\n", maps.size(), big.size());

    // warm-up (untimed): relief's and PoCL's caches for both sizes
    for (const std::string& png : {maps.front().png, big.front().png})
        run({relief, png, "--height", "-o", work + "/warm.exr"});

    // throughput
    std::ofstream jobs(work + "/jobs.txt");
    for (const Map& m : maps)
        jobs << "'" << m.png << "' --height -o '" << work << "/out/" << m.name << ".exr'\n";
    jobs.close();
    double peer_total = 0, single_total = 0;
    for (const Map& m : maps)
        peer_total += run({peer, m.tga, work + "/out/" + m.name + ".peer.tga", "none"});
    const double batch = run({relief, "--batch", work + "/jobs.txt"});
    double worst = 0;
    for (const Map& m : maps) {
        const std::string single = work + "/out/" + m.name + ".single.exr";
        single_total += run({relief, m.png, "--height", "-o", single});
        worst =
            std::max(worst, bench::max_diff_over_std(bench::read_channels(single),
                                                     bench::read_channels(work + "/out/" + m.name + ".exr")));
    }
    const double update = run({relief, "--batch", work + "/jobs.txt", "--update"});

    // each size on its own, alternating with the peer
    struct SizeBatch {
        int size;
        std::size_t maps = 0;
        double peer = 0, batch = 0;  // medians, seconds per map
    };
    std::vector<SizeBatch> by_size = {{512}, {1024}};
    for (SizeBatch& b : by_size) {
        const std::string list = work + "/jobs" + std::to_string(b.size) + ".txt";
        std::ofstream f(list);
        for (const Map& m : maps)
            if (m.size == b.size) {
                f << "'" << m.png << "' --height -o '" << work << "/out/" << m.name << ".size.exr'\n";
                ++b.maps;
            }
        f.close();
        std::vector<double> p, r;
        for (int k = 0; k < runs; ++k) {
            double t = 0;
            for (const Map& m : maps)
                if (m.size == b.size)
                    t += run({peer, m.tga, work + "/out/" + m.name + ".peer.tga", "none"});
            p.push_back(t / double(b.maps));
            r.push_back(run({relief, "--batch", list}) / double(b.maps));
        }
        b.peer = median(p);
        b.batch = median(r);
        for (const Map& m : maps)
            if (m.size == b.size)
                worst = std::max(worst, bench::max_diff_over_std(
                                            bench::read_channels(work + "/out/" + m.name + ".size.exr"),
                                            bench::read_channels(work + "/out/" + m.name + ".single.exr")));
    }

    // a batch's per-map split, as -v reports it: each job's read, --height
    // and write, and the overlap line
    std::string batch_split;
    {
        run({relief, "-v", "--batch", work + "/jobs512.txt"}, work + "/batch_split.txt");
        std::vector<double> reads, heights, writes, jobs_s;
        std::ifstream in(work + "/batch_split.txt");
        for (std::string l; std::getline(in, l);) {
            int job = 0;
            double sec = 0;
            char what[16] = {};
            if (std::sscanf(l.c_str(), "relief: job %d: %15s", &job, what) == 2) {
                const std::size_t colon = l.rfind(": ");
                if (colon == std::string::npos || std::sscanf(l.c_str() + colon + 2, "%lf s", &sec) != 1)
                    continue;
                const std::string w = what;
                if (w == "read")
                    reads.push_back(sec);
                else if (w == "--height:")
                    heights.push_back(std::strtod(l.c_str() + l.find("--height: ") + 10, nullptr));
                else if (w == "-o")
                    writes.push_back(sec);
            } else if (std::sscanf(l.c_str(), "relief: job %d (%*[^)]): ok, %lf s", &job, &sec) == 2) {
                jobs_s.push_back(sec);
            } else if (l.rfind("relief: overlap: ", 0) == 0) {
                batch_split += "    " + l + "\n";
            }
        }
        char text[512];
        std::snprintf(text, sizeof text,
                      "Per map, medians over %zu jobs: read (the wait for the image read ahead) %.4f s, "
                      "--height %.4f s, write (behind) %.4f s; a job from its start to its outputs written "
                      "%.4f s.\n\n",
                      jobs_s.size(), median(reads), median(heights), median(writes), median(jobs_s));
        batch_split = text + batch_split;
    }

    // single maps, alternating
    struct Single {
        int size;
        std::string png, tga;
        double peer = 0, relief = 0;
    };
    std::vector<Single> singles = {{512, maps.front().png, maps.front().tga},
                                   {1024, big.front().png, big.front().tga}};
    {
        std::vector<Map> huge = cut_maps(data, 2048, 1, work + "/maps");
        if (!huge.empty())
            singles.push_back({2048, huge.front().png, huge.front().tga});
    }
    for (Single& s : singles) {
        run({relief, s.png, "--height", "-o", work + "/single.exr"});  // warm
        std::vector<double> p, r;
        for (int k = 0; k < runs; ++k) {
            p.push_back(run({peer, s.tga, work + "/single.peer.tga", "none"}));
            r.push_back(run({relief, s.png, "--height", "-o", work + "/single.exr"}));
        }
        s.peer = median(p);
        s.relief = median(r);
    }

    // the overhead split of one 512^2 map, as -v reports it
    run({relief, "-v", maps.front().png, "--height", "-o", work + "/split.exr"}, work + "/split.txt");
    std::string split;
    {
        std::ifstream in(work + "/split.txt");
        for (std::string line; std::getline(in, line);)
            if (line.find("process start") != std::string::npos ||
                line.find("--height:") != std::string::npos || line.find(": 0.") != std::string::npos)
                split += "    " + line + "\n";
    }

    const std::size_t n = maps.size();
    std::ostringstream md;
    char line[512];
    md << "# Farm benchmark: relief against the peer run once per file\n\n";
    md << "Whole processes, warm caches; " << n << " real maps (" << n - big.size() << " of 512^2, "
       << big.size() << " of 1024^2, 8-bit), default `--height`.\n\n";
    md << "| what | seconds | per map | vs peer |\n|---|---|---|---|\n";
    std::snprintf(line, sizeof line, "| peer, one process per file | %.2f | %.3f | 1.00 |\n", peer_total,
                  peer_total / n);
    md << line;
    std::snprintf(line, sizeof line, "| relief --batch | %.2f | %.3f | %.2f |\n", batch, batch / n,
                  batch / peer_total);
    md << line;
    std::snprintf(line, sizeof line, "| relief, one process per file | %.2f | %.3f | %.2f |\n", single_total,
                  single_total / n, single_total / peer_total);
    md << line;
    std::snprintf(line, sizeof line,
                  "| relief --batch --update, all skipped | %.2f | %.3f | %.2f of the first batch |\n",
                  update, update / n, update / batch);
    md << line;
    std::snprintf(line, sizeof line,
                  "\nEvery batch output equals its single-map run: largest difference %.2g of std "
                  "(0: the same bits).\n\n",
                  worst);
    md << line;
    md << "Each size on its own, medians of " << runs
       << " alternating runs (the peer once per file, one `relief --batch` per size):\n\n"
          "| size | maps | peer s/map | relief --batch s/map | relief / peer |\n|---|---|---|---|---|\n";
    for (const SizeBatch& b : by_size) {
        std::snprintf(line, sizeof line, "| %d^2 | %zu | %.4f | %.4f | %.2f |\n", b.size, b.maps, b.peer,
                      b.batch, b.batch / b.peer);
        md << line;
    }
    md << "\nA batch of the 512^2 maps, `relief -v --batch`:\n\n" << batch_split << "\n";
    md << "Single maps, medians of " << runs
       << " alternating runs:\n\n| size | peer s | relief s | relief / peer |\n|---|---|---|---|\n";
    for (const Single& s : singles) {
        std::snprintf(line, sizeof line, "| %d^2 | %.3f | %.3f | %.2f |\n", s.size, s.peer, s.relief,
                      s.relief / s.peer);
        md << line;
    }
    md << "\nOne 512^2 map, `relief -v`:\n\n" << split;
    std::ofstream(g_out + "/farm.md") << md.str();
    std::ofstream csv(g_out + "/farm.csv");
    csv << "what,seconds,maps\n";
    csv << "peer_per_file," << peer_total << "," << n << "\n";
    csv << "relief_batch," << batch << "," << n << "\n";
    csv << "relief_per_file," << single_total << "," << n << "\n";
    csv << "relief_update_all_skipped," << update << "," << n << "\n";
    for (const SizeBatch& b : by_size)
        csv << "size_" << b.size << "_peer_per_map," << b.peer << "," << b.maps << "\nsize_" << b.size
            << "_batch_per_map," << b.batch << "," << b.maps << "\n";
    for (const Single& s : singles)
        csv << "single_" << s.size << "_peer," << s.peer << ",1\nsingle_" << s.size << "_relief," << s.relief
            << ",1\n";
    std::fputs(md.str().c_str(), stdout);
    return worst == 0 ? 0 : 1;  // batches must give the single runs' bits
}
