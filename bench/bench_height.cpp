// SPDX-License-Identifier: Apache-2.0
// Run time against error for every integration method (issue 3, docs/design.md §5).
//
//   bench_height [--sizes 512,1024,2048,4096] [--runs 3] [--budget 120]
//                [--out bench-results] [--no-real] [--only METHOD]
//
// For each size, writes a float normal map of a smooth periodic field with
// exact normals, then times whole `relief` processes (fork + exec, warm PoCL
// kernel caches; the first run of each size with empty caches is reported
// as cold) and measures the error of the result against exact truth:
//   rays     RMSE against h - mean_disk_R(h) (exact via Bessel J1), / std
//   poisson  RMSE against h - mean(h), / std; highpass against the filtered h
// With ../shared/data present, the real normal/height pairs there are run
// too and scored by NRMSE after the best affine fit (docs/design.md §5).
// Reference-kernel runs predicted to take longer than --budget seconds are
// listed as skipped. Writes results.csv, results.md and plot.gp (gnuplot:
// run time against error, log axes, one curve per method) into --out.
#include <OpenImageIO/imagebuf.h>

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
#include "support/accuracy.h"
#include "run_process.h"

namespace fs = std::filesystem;

namespace {

struct Wave {
    int kx, ky;
    double a, phase;
};
const Wave kWaves[] = {{1, 0, 8.0, 0.2}, {2, 3, 3.0, 1.0}, {-5, 2, 1.5, 2.5}, {9, 7, 0.6, 0.4}};

// A first run of cmd (cold where `cache` is new), then `runs` warm ones.
struct Runs {
    double cold = 0;           // seconds
    std::vector<double> warm;  // seconds
    double rss_mb = 0;         // the peak of them all
};

Runs run_repeated(const std::vector<std::string>& cmd, const std::string& cache, int runs)
{
    Runs r;
    const bench::Timing cold = bench::run_measured(cmd, cache);
    r.cold = cold.wall;
    r.rss_mb = cold.rss_mb;
    for (int i = 0; i < runs; ++i) {
        const bench::Timing t = bench::run_measured(cmd, cache);
        r.warm.push_back(t.wall);
        r.rss_mb = std::max(r.rss_mb, t.rss_mb);
    }
    return r;
}

double rel_rmse(const std::vector<float>& got, const std::vector<double>& truth)
{
    double se = 0, st = 0, mean = 0;
    for (double t : truth)
        mean += t;
    mean /= double(truth.size());
    double gmean = 0;
    for (float g : got)
        gmean += g;
    gmean /= double(got.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
        const double d = (got[i] - gmean) - (truth[i] - mean);
        se += d * d;
        st += (truth[i] - mean) * (truth[i] - mean);
    }
    return std::sqrt(se / st);
}

struct Case {
    std::string method;  // poisson-periodic, rays-fast, ...
    std::string mods;    // --height modifiers
    int rays = 0;
    double radius = 0;
    double highpass = 0;
    bool reference = false;
};

std::vector<Case> analytic_cases()
{
    std::vector<Case> cases;
    cases.push_back({"poisson periodic", "method=poisson:boundary=periodic"});
    cases.push_back({"poisson free", "method=poisson:boundary=free"});
    Case hp{"poisson highpass=64", "method=poisson:boundary=periodic:highpass=64"};
    hp.highpass = 64;
    cases.push_back(hp);
    for (bool reference : {false, true})
        for (int rays : {8, 16, 32, 64})
            for (double radius : {16.0, 32.0, 64.0, 128.0, 256.0}) {
                Case c;
                c.method =
                    std::string(reference ? "rays reference" : "rays fast") + " J=" + std::to_string(rays);
                c.mods = std::string("method=rays:boundary=periodic:impl=") +
                         (reference ? "reference" : "fast") + ":rays=" + std::to_string(rays) +
                         ":radius=" + std::to_string(int(radius));
                c.rays = rays;
                c.radius = radius;
                c.reference = reference;
                cases.push_back(c);
            }
    return cases;
}

using bench::median;

}  // namespace

int main(int argc, char** argv)
{
    std::vector<int> sizes{512, 1024, 2048, 4096};
    int runs = 3;
    double budget = 120;
    fs::path out = "bench-results";
    bool real = true;
    std::string only;  // run only the methods whose name contains this
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "bench: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--sizes") {
            sizes.clear();
            std::stringstream ss(value());
            for (std::string s; std::getline(ss, s, ',');)
                sizes.push_back(std::atoi(s.c_str()));
        } else if (a == "--runs")
            runs = std::max(1, std::atoi(value().c_str()));
        else if (a == "--budget")
            budget = std::atof(value().c_str());
        else if (a == "--out")
            out = value();
        else if (a == "--no-real")
            real = false;
        else if (a == "--only")
            only = value();
        else {
            std::fprintf(stderr,
                         "usage: %s [--sizes a,b] [--runs N] [--budget S] [--out DIR] [--no-real] "
                         "[--only METHOD]\n",
                         argv[0]);
            return 2;
        }
    }
    fs::create_directories(out);
    const fs::path work = out / "work";
    fs::create_directories(work);
    std::ofstream csv(out / "results.csv");
    csv << "data,size,method,modifiers,cold_s,median_s,min_s,max_s,peak_rss_mb,error,error_measure\n";
    std::ofstream md(out / "results.md");
    md << "| data | size | method | modifiers | cold s | median s | peak RSS MB | error | measure |\n"
       << "|---|---|---|---|---|---|---|---|---|\n";
    auto record = [&](const std::string& data, int size, const Case& c, double cold,
                      const std::vector<double>& t, double rss, double err, const char* measure) {
        char line[512];
        std::snprintf(line, sizeof line, "%s,%d,%s,%s,%.3f,%.3f,%.3f,%.3f,%.0f,%.3e,%s\n", data.c_str(), size,
                      c.method.c_str(), c.mods.c_str(), cold, median(t),
                      *std::min_element(t.begin(), t.end()), *std::max_element(t.begin(), t.end()), rss, err,
                      measure);
        csv << line;
        csv.flush();
        std::snprintf(line, sizeof line, "| %s | %d | %s | `%s` | %.3f | %.3f | %.0f | %.2e | %s |\n",
                      data.c_str(), size, c.method.c_str(), c.mods.c_str(), cold, median(t), rss, err,
                      measure);
        md << line;
        md.flush();
        std::printf("%s", line);
        std::fflush(stdout);
    };
    auto skip = [&](const std::string& data, int size, const Case& c, double predicted) {
        char line[512];
        std::snprintf(line, sizeof line,
                      "| %s | %d | %s | `%s` | skipped: predicted %.0f s > budget | | | | |\n", data.c_str(),
                      size, c.method.c_str(), c.mods.c_str(), predicted);
        md << line;
        std::printf("%s", line);
    };

    double reference_rate = 0;  // seconds per texel * ray * radius, once measured
    for (int n : sizes) {
        double overhead = 1e300;  // the fastest run of this size: start-up, I/O
        // The field's normals (OpenGL, float, exact).
        std::vector<float> px(std::size_t(n) * n * 3);
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                double gx = 0, gy = 0;
                for (const Wave& w : kWaves) {
                    double arg = 2 * M_PI * (w.kx * double(x) + w.ky * double(y)) / n + w.phase;
                    gx -= w.a * std::sin(arg) * 2 * M_PI * w.kx / n;
                    gy -= w.a * std::sin(arg) * 2 * M_PI * w.ky / n;
                }
                double len = std::sqrt(gx * gx + gy * gy + 1);
                std::size_t i = std::size_t(y) * n + x;
                px[3 * i] = float(-gx / len);
                px[3 * i + 1] = float(gy / len);  // OpenGL: green = -(row component)
                px[3 * i + 2] = float(1 / len);
            }
        const std::string normal = (work / "normal.exr").string();
        const std::string height = (work / "height.exr").string();
        bench::write_rgb(normal, n, OIIO::TypeDesc::FLOAT, px);
        const std::string cache = (work / ("caches-" + std::to_string(n))).string();
        fs::remove_all(cache);
        bool first = true;
        for (const Case& c : analytic_cases()) {
            if (!only.empty() && c.method.find(only) == std::string::npos)
                continue;
            const double work_units = double(n) * n * c.rays * c.radius;
            if (c.reference && reference_rate > 0 && reference_rate * work_units > budget) {
                skip("analytic", n, c, overhead + reference_rate * work_units);
                continue;
            }
            const std::vector<std::string> cmd{RELIEF_CLI, normal, "--height:normal=opengl:" + c.mods, "-o",
                                               height};
            // Cold: only the first case of each size runs with an empty cache.
            const Runs timed = run_repeated(cmd, cache, runs);
            const std::vector<double>& t = timed.warm;
            overhead = std::min(overhead, median(t));
            if (c.reference && median(t) > 2 * overhead)
                reference_rate = std::max(reference_rate, (median(t) - overhead) / work_units);
            int w = 0, h = 0;
            auto got = bench::read_channels(height, w, h, 1);
            std::vector<double> truth(got.size());
            for (int y = 0; y < n; ++y)
                for (int x = 0; x < n; ++x) {
                    double v = 0;
                    for (const Wave& wv : kWaves) {
                        double arg = 2 * M_PI * (wv.kx * double(x) + wv.ky * double(y)) / n + wv.phase;
                        double k = 2 * M_PI * std::hypot(wv.kx, wv.ky) / n;
                        double gain = 1.0;
                        if (c.radius > 0)
                            gain = 1.0 - 2.0 * std::cyl_bessel_j(1.0, k * c.radius) / (k * c.radius);
                        if (c.highpass > 0) {
                            double s = c.highpass * std::sqrt(2 * std::log(2.0)) / (2 * M_PI);
                            gain = 1.0 - std::exp(-0.5 * k * k * s * s);
                        }
                        v += wv.a * std::cos(arg) * gain;
                    }
                    truth[std::size_t(y) * n + x] = v;
                }
            record("analytic", n, c, first ? timed.cold : NAN, t, timed.rss_mb, rel_rmse(got, truth),
                   "RMSE/std vs exact");
            first = false;
        }
    }

    const fs::path shared = fs::path(RELIEF_SHARED_DATA);
    if (real && fs::is_directory(shared)) {
        const std::string cache = (work / "caches-real").string();
        const std::vector<fs::path> dirs = bench::map_folders(shared);
        const std::vector<Case> cases{{"poisson auto", "method=poisson"},
                                      {"rays fast J=32", "method=rays:rays=32:radius=64"}};
        for (const auto& d : dirs) {
            int w = 0, h = 0;
            auto truth = bench::read_channels((d / "height.png").string(), w, h, 1);
            for (const Case& c : cases) {
                const std::string height = (work / "real.exr").string();
                const std::vector<std::string> cmd{RELIEF_CLI, (d / "normal.png").string(),
                                                   "--height:" + c.mods, "-o", height};
                const Runs timed = run_repeated(cmd, cache, runs);
                int ew = 0, eh = 0;
                auto est = bench::read_channels(height, ew, eh, 1);
                if (ew != w || eh != h) {
                    std::fprintf(stderr, "bench: %s: height.png is %dx%d, normal map %dx%d: skipped\n",
                                 d.filename().c_str(), w, h, ew, eh);
                    break;
                }
                record(d.filename().string(), w, c, NAN, timed.warm, timed.rss_mb,
                       relief::test::nrmse_affine(est, truth), "NRMSE vs height.png (affine fit)");
            }
        }
    }

    // Run time against error, one curve per method, one panel per size.
    std::ofstream gp(out / "plot.gp");
    std::vector<std::string> methods{"poisson periodic", "poisson free", "poisson highpass=64"};
    for (const char* impl : {"rays fast", "rays reference"})
        for (int rays : {8, 16, 32, 64})
            methods.push_back(std::string(impl) + " J=" + std::to_string(rays));
    gp << "# gnuplot " << (out / "plot.gp").string() << "  -> plot.png\n"
       << "set terminal pngcairo size " << 620 * sizes.size() << ",760 font ',10'\n"
       << "set output '" << (out / "plot.png").string() << "'\n"
       << "set datafile separator ','\nset logscale xy\nset format x '10^{%L}'\nset format y '%g'\n"
       << "set grid\nset key bottom left font ',8'\nset xrange [1e-8:1]\n"
       << "set xlabel 'error (RMSE / std against exact truth)'\n"
       << "set ylabel 'whole-process time, s (median, warm)'\n"
       << "set multiplot layout 1," << sizes.size()
       << " title 'relief: run time against error, analytic fields (2-core PoCL)'\n";
    for (int n : sizes) {
        gp << "set title '" << n << "^2'\nplot ";
        for (std::size_t m = 0; m < methods.size(); ++m)
            gp << (m ? ", \\\n  " : "") << "'" << (out / "results.csv").string()
               << "' using (strcol(1) eq 'analytic' && $2 == " << n << " && strcol(3) eq '" << methods[m]
               << "' ? $10 : 1/0):6 with linespoints lc " << m + 1 << " pt " << m % 14 + 1 << " title '"
               << methods[m] << "'";
        gp << "\n";
    }
    gp << "unset multiplot\n";
    fs::remove_all(work);
    std::printf("wrote %s, %s, %s\n", (out / "results.csv").c_str(), (out / "results.md").c_str(),
                (out / "plot.gp").c_str());
    return 0;
}
