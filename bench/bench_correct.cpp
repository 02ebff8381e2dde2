// SPDX-License-Identifier: Apache-2.0
// Distortion correction benchmark (docs/design.md §4.5; not run by ctest):
//  - iterations per second per megatexel (single resolution, no skipping);
//  - time to get within 1% of the converged energy (99% of the achievable
//    energy decrease: E <= E* + 0.01 (E0 - E*), E* = the coarse-to-fine
//    result at tolerance 1e-6), with and without coarse-to-fine;
//  - time to convergence (relative energy change < 1e-5) with coarse-to-fine;
//  - a before/after picture: anisotropy s1/s2 per texel before and after, and
//    a checker baked through the offsets;
//  - on real maps (--maps): the time-to-energy curve of each line search,
//    alone, with hat moves and with global steps (energy against seconds over a sweep of
//    tolerances, in-process, warm),
//    and, with --baseline, whole processes of this build's CLI against an
//    older one (e.g. the first landed correction), medians of --runs,
//    energies scored here from the written offset maps.
// Usage: bench_correct [--sizes 512,1024|none] [--budget SECONDS] [--out DIR]
//                      [--maps castell,... (folders of --data)] [--data DIR]
//                      [--baseline OLD_RELIEF] [--runs 3] [--tolerances 1e-3,...|none]
// Synthetic heights: a terrain (bumps, ridges, a plateau) at every size.
// Everything runs at scale 0.05, theta 5; nodes=center in process (synthetic:
// periodic; real maps: boundary=auto, as the CLI decides), the CLI's default
// (corner nodes) in the whole-process comparison.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/strutil.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "relief/relief.h"
#include "image_files.h"
#include "run_process.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

OIIO::ImageBuf terrain(int n)
{
    // Resolution-independent: every feature is defined in texture units.
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    struct Bump {
        double x, y, r, a;
    };
    std::vector<Bump> bumps;
    for (int k = 0; k < 40; ++k)
        bumps.push_back({u(rng), u(rng), 0.02 + 0.08 * u(rng), 0.2 + 0.8 * u(rng)});
    OIIO::ImageBuf b(OIIO::ImageSpec(n, n, 1, OIIO::TypeDesc::FLOAT));
    std::vector<float> px(std::size_t(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const double s = (x + 0.5) / n, t = (y + 0.5) / n;
            double h = 0.15 * std::sin(2 * kPi * (3 * s + t)) * std::sin(2 * kPi * 2 * t);
            for (const auto& m : bumps) {
                double dx = std::remainder(s - m.x, 1.0), dy = std::remainder(t - m.y, 1.0);
                h += m.a * std::exp(-(dx * dx + dy * dy) / (m.r * m.r));
            }
            // A plateau with steep flanks.
            const double dx = std::remainder(s - 0.7, 1.0), dy = std::remainder(t - 0.3, 1.0);
            h += 0.6 / (1 + std::exp((std::sqrt(dx * dx + dy * dy) - 0.12) * 120));
            px[std::size_t(y) * n + x] = float(h);
        }
    b.set_pixels(b.roi(), OIIO::TypeDesc::FLOAT, px.data());
    return b;
}

struct Run {
    double seconds = 0, energy = 0, energy_before = 0;
    int iterations = 0;
    relief::CorrectReport report;
    OIIO::ImageBuf offsets;
};

Run correct(const OIIO::ImageBuf& h, int levels, int iterations, double tolerance, bool skip = true)
{
    relief::CorrectOptions o;
    o.scale = 0.05f;
    o.nodes = relief::CorrectNodes::Center;
    o.boundary = relief::CorrectBoundary::Periodic;
    o.levels = levels;
    o.iterations = iterations;
    o.tolerance = float(tolerance);
    o.max_iterations = 100000;
    o.skip_tiles = skip;
    Run r;
    o.report = &r.report;
    const auto t0 = std::chrono::steady_clock::now();
    if (!relief::correct(r.offsets, h, o)) {
        std::fprintf(stderr, "bench_correct: %s\n", relief::geterror().c_str());
        std::exit(1);
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.energy = r.report.energy_after;
    r.energy_before = r.report.energy_before;
    r.iterations = r.report.iterations;
    return r;
}

// Anisotropy s1/s2 of each texel's first owned triangle (centre nodes,
// periodic), for the picture.
std::vector<float> anisotropy(const OIIO::ImageBuf& h, const OIIO::ImageBuf* off, double scale)
{
    const int n = h.spec().width;
    std::vector<float> z(std::size_t(n) * n), c(2 * std::size_t(n) * n, 0.0f), out(z.size());
    h.get_pixels(h.roi(), OIIO::TypeDesc::FLOAT, z.data());
    if (off) {
        OIIO::ROI r = off->roi();
        r.chend = 2;
        off->get_pixels(r, OIIO::TypeDesc::FLOAT, c.data());
    }
    auto at = [&](int x, int y) { return std::size_t((y + n) % n) * n + (x + n) % n; };
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const std::size_t p = at(x, y), a = at(x + 1, y), b = at(x + 1, y - 1);
            const double e1[2] = {1 + (c[2 * a] - c[2 * p]) * n, (c[2 * a + 1] - c[2 * p + 1]) * n};
            const double e2[2] = {1 + (c[2 * b] - c[2 * p]) * n, -1 + (c[2 * b + 1] - c[2 * p + 1]) * n};
            const double f1[3] = {1, 0, (z[a] - z[p]) * scale * n},
                         f2[3] = {1, -1, (z[b] - z[p]) * scale * n};
            const double auv = 0.5 * (e1[1] * e2[0] - e1[0] * e2[1]);
            const double cx = f1[1] * f2[2] - f1[2] * f2[1], cy = f1[2] * f2[0] - f1[0] * f2[2],
                         cz = f1[0] * f2[1] - f1[1] * f2[0];
            const double a3 = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
            auto d3 = [](const double* u, const double* v) {
                return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
            };
            const double q = d3(f1, f1) * (e2[0] * e2[0] + e2[1] * e2[1]) -
                             2 * d3(f1, f2) * (e1[0] * e2[0] + e1[1] * e2[1]) +
                             d3(f2, f2) * (e1[0] * e1[0] + e1[1] * e1[1]);
            const double k = q / (4 * a3 * auv);
            out[p] = float(0.5 * (k + std::sqrt(std::max(0.0, k * k - 4))));
        }
    return out;
}

struct Scored {
    double energy = 0.0;
    long long flipped = 0;
};

// The total energy of an offset map (centre nodes, texture units; each
// node's two owned triangles [p, p+(1,0), p+(1,-1)] and [p, p+(1,-1),
// p+(0,-1)], wrapping when periodic, else only those inside the map), in
// double, written here from docs/design.md §4.5 and independent of the library:
// E = Q/(4 A3 Auv) ((A3^2 + Auv^2)/(A3 Auv))^theta.
Scored score(const std::vector<float>& h, int w, int ht, const std::vector<float>& off, double scale,
             double theta, bool periodic)
{
    Scored r;
    auto at = [&](int x, int y) { return std::size_t((y + ht) % ht) * w + (x + w) % w; };
    const int tri[2][2][2] = {{{1, 0}, {1, -1}}, {{1, -1}, {0, -1}}};
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x) {
            if (!periodic && (x + 1 >= w || y < 1))
                continue;
            const std::size_t p = at(x, y);
            for (const auto& t : tri) {
                double e[2][2], f[2][3];
                for (int k = 0; k < 2; ++k) {
                    const int dx = t[k][0], dy = t[k][1];
                    const std::size_t q = at(x + dx, y + dy);
                    e[k][0] = dx + (double(off[2 * q]) - off[2 * p]) * w;
                    e[k][1] = dy + (double(off[2 * q + 1]) - off[2 * p + 1]) * ht;
                    f[k][0] = dx;
                    f[k][1] = dy;
                    f[k][2] = (double(h[q]) - h[p]) * scale * w;
                }
                const double auv = 0.5 * (e[0][1] * e[1][0] - e[0][0] * e[1][1]);
                if (!(auv > 0.0)) {
                    ++r.flipped;
                    continue;
                }
                const double cx = f[0][1] * f[1][2] - f[0][2] * f[1][1],
                             cy = f[0][2] * f[1][0] - f[0][0] * f[1][2],
                             cz = f[0][0] * f[1][1] - f[0][1] * f[1][0];
                const double a3 = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
                auto d3 = [](const double* u, const double* v) {
                    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
                };
                auto d2 = [](const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1]; };
                const double q = d3(f[0], f[0]) * d2(e[1], e[1]) - 2 * d3(f[0], f[1]) * d2(e[0], e[1]) +
                                 d3(f[1], f[1]) * d2(e[0], e[0]);
                r.energy += q / (4 * a3 * auv) * std::pow((a3 * a3 + auv * auv) / (a3 * auv), theta);
            }
        }
    return r;
}

struct Variant {
    const char* name;
    relief::CorrectSearch search;
    float relax;
    relief::CorrectHats hats;
    relief::CorrectGlobal global;
};
// (Names without commas: they are CSV fields, which gnuplot splits.)
const Variant kVariants[] = {
    {"ternary (first version)", relief::CorrectSearch::Ternary, 1.0f, relief::CorrectHats::Off,
     relief::CorrectGlobal::Off},
    {"golden with relax 1.5", relief::CorrectSearch::Golden, 1.5f, relief::CorrectHats::Off,
     relief::CorrectGlobal::Off},
    {"brent", relief::CorrectSearch::Brent, 1.0f, relief::CorrectHats::Off, relief::CorrectGlobal::Off},
    {"brent with relax 1.5 alone", relief::CorrectSearch::Brent, 1.5f, relief::CorrectHats::Off,
     relief::CorrectGlobal::Off},
    {"brent with relax 1.5 and hat moves", relief::CorrectSearch::Brent, 1.5f, relief::CorrectHats::Auto,
     relief::CorrectGlobal::Off},
    {"brent with relax 1.5 and global steps (default)", relief::CorrectSearch::Brent, 1.5f,
     relief::CorrectHats::Off, relief::CorrectGlobal::Auto}};

// Real maps: the time-to-energy curves, and the whole-process comparison
// against --baseline.
void real_maps(const std::vector<std::string>& names, const std::string& data, const std::string& baseline,
               int runs, const std::vector<double>& tolerances, const std::string& out_dir)
{
    // The whole processes run the CLI's defaults at scale 0.05 (corner
    // nodes, theta 5), as a user would.
    const std::string mods = "--correct:scale=0.05";
    const std::string work = out_dir + "/correct-work";
    std::filesystem::create_directories(work);
    // Each part writes its files only when it runs (--tolerances none, no
    // --baseline), so that the two can run separately.
    std::ofstream curves, md, csv;
    if (!tolerances.empty()) {
        curves.open(out_dir + "/correct_curves.csv");
        curves << "map,variant,tolerance,seconds,energy,iterations\n";
    }
    if (!baseline.empty()) {
        md.open(out_dir + "/correct_maps.md");
        csv.open(out_dir + "/correct_maps.csv");
        md << "| map | size | boundary | baseline s | this build s | ratio | baseline energy | this build "
              "energy | "
              "energy ratio | flipped (baseline, this) |\n|---|---|---|---|---|---|---|---|---|---|\n";
        csv << "map,width,height,boundary,baseline_s,current_s,ratio,baseline_energy,current_energy,"
               "flipped_baseline,flipped_current\n";
    }
    for (const std::string& name : names) {
        const std::string path =
            name.find('/') != std::string::npos ? name : data + "/" + name + "/height.png";
        int w = 0, h = 0;
        const std::vector<float> hts = bench::read_channels(path, w, h, 1);
        OIIO::ImageBuf hb(OIIO::ImageSpec(w, h, 1, OIIO::TypeDesc::FLOAT));
        hb.set_pixels(hb.roi(), OIIO::TypeDesc::FLOAT, hts.data());
        for (const Variant& v : kVariants)
            for (double tol : tolerances) {
                relief::CorrectOptions o;
                o.scale = 0.05f;
                o.nodes = relief::CorrectNodes::Center;
                o.search = v.search;
                o.relax = v.relax;
                o.hats = v.hats;
                o.global = v.global;
                o.tolerance = float(tol);
                relief::CorrectReport rep;
                o.report = &rep;
                OIIO::ImageBuf off;
                const auto t0 = std::chrono::steady_clock::now();
                if (!relief::correct(off, hb, o)) {
                    std::fprintf(stderr, "bench_correct: %s\n", relief::geterror().c_str());
                    std::exit(1);
                }
                const double sec =
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                std::fprintf(stderr, "bench_correct: %s, %s, tolerance %g: %.2f s, energy %.9g\n",
                             name.c_str(), v.name, tol, sec, rep.energy_after);
                curves << name << ',' << v.name << ',' << tol << ',' << sec << ',' << std::setprecision(10)
                       << rep.energy_after << std::setprecision(6) << ',' << rep.iterations << '\n';
                curves.flush();
            }
        if (baseline.empty())
            continue;
        // Whole processes, alternating, after one warm-up run each.
        const std::string cur_out = work + "/current.exr", old_out = work + "/baseline.exr";
        const std::string cli = RELIEF_CLI;
        bench::run_process({cli, path, mods, "-o", cur_out}, work + "/current");
        bench::run_process({baseline, path, mods, "-o", old_out}, work + "/baseline");
        std::vector<double> tc, tb;
        for (int k = 0; k < runs; ++k) {
            tb.push_back(bench::run_process({baseline, path, mods, "-o", old_out}, work + "/baseline"));
            tc.push_back(bench::run_process({cli, path, mods, "-o", cur_out}, work + "/current"));
        }
        int ow = 0, oh = 0;
        std::string bc_old, bc_cur;
        const auto off_old = bench::read_channels(old_out, ow, oh, 2, &bc_old),
                   off_cur = bench::read_channels(cur_out, ow, oh, 2, &bc_cur);
        const Scored so = score(hts, w, h, off_old, 0.05, 5.0, bc_old == "periodic");
        const Scored sc = score(hts, w, h, off_cur, 0.05, 5.0, bc_cur == "periodic");
        const double mb = bench::median(tb), mc = bench::median(tc);
        std::printf("%s %dx%d (%s): baseline %.2f s, this build %.2f s (%.3fx); energy %.9g -> %.9g (%.5f); "
                    "flipped %lld, %lld\n",
                    name.c_str(), w, h, bc_cur.c_str(), mb, mc, mc / mb, so.energy, sc.energy,
                    sc.energy / so.energy, so.flipped, sc.flipped);
        std::fflush(stdout);
        char line[512];
        std::snprintf(line, sizeof line,
                      "| %s | %d×%d | %s | %.2f | %.2f | %.3f× | %.7g | %.7g | %.5f | %lld, %lld |\n",
                      name.c_str(), w, h, bc_cur.c_str(), mb, mc, mc / mb, so.energy, sc.energy,
                      sc.energy / so.energy, so.flipped, sc.flipped);
        md << line;
        md.flush();
        csv << name << ',' << w << ',' << h << ',' << bc_cur << ',' << mb << ',' << mc << ',' << mc / mb
            << ',' << std::setprecision(10) << so.energy << ',' << sc.energy << std::setprecision(6) << ','
            << so.flipped << ',' << sc.flipped << '\n';
        csv.flush();
    }
    std::filesystem::remove_all(work);
    if (tolerances.empty())
        return;
    // Energy above the best found for the map, against seconds: one curve
    // per line search, one panel per map.
    std::ofstream gp(out_dir + "/correct_curves.gp");
    gp << "# gnuplot " << out_dir << "/correct_curves.gp  -> correct_curves.png\n"
       << "set terminal pngcairo size " << 520 * names.size() << ",480 font ',10'\n"
       << "set output '" << out_dir << "/correct_curves.png'\n"
       << "set datafile separator ','\nset logscale y\nset grid\nset key top right font ',8' noenhanced\n"
       << "set xlabel 'seconds (in-process, warm; tolerances " << tolerances.front() << " .. "
       << tolerances.back() << ")'\n"
       << "set ylabel 'energy / lowest energy found - 1 (+1e-7)'\n"
       << "set multiplot layout 1," << names.size()
       << " title 'relief --correct: energy against time (2-core PoCL)'\n";
    for (const std::string& name : names) {
        gp << "best = 1e300\nstats '" << out_dir << "/correct_curves.csv' using (strcol(1) eq '" << name
           << "' ? $5 : 1/0) nooutput\nbest = STATS_min\nset title '" << name << "' noenhanced\nplot ";
        for (std::size_t v = 0; v < std::size(kVariants); ++v)
            gp << (v ? ", \\\n  " : "") << "'" << out_dir << "/correct_curves.csv' using (strcol(1) eq '"
               << name << "' && strcol(2) eq '" << kVariants[v].name
               << "' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc " << v + 1 << " pt " << v + 4
               << " title '" << kVariants[v].name << "'";
        gp << "\n";
    }
    gp << "unset multiplot\n";
    gp.close();
    if (std::system(
            ("command -v gnuplot >/dev/null && gnuplot '" + out_dir + "/correct_curves.gp'").c_str()) != 0)
        std::fprintf(stderr,
                     "bench_correct: gnuplot missing or failed; the curves are in correct_curves.csv\n");
}

}  // namespace

int main(int argc, char** argv)
{
    std::vector<int> sizes{512, 1024};
    double budget = 300.0;
    std::string out_dir = "bench/results", data = RELIEF_SHARED_DATA, baseline;
    std::vector<std::string> maps;
    std::vector<double> tolerances{1e-3, 1e-4, 1e-5};
    int runs = 3;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--sizes" && i + 1 < argc) {
            sizes.clear();
            for (const std::string& t : OIIO::Strutil::splits(argv[++i], ","))
                if (t != "none")
                    sizes.push_back(std::stoi(t));
        } else if (a == "--budget" && i + 1 < argc) {
            budget = std::stod(argv[++i]);
        } else if (a == "--out" && i + 1 < argc) {
            out_dir = argv[++i];
        } else if (a == "--maps" && i + 1 < argc) {
            maps = OIIO::Strutil::splits(argv[++i], ",");
        } else if (a == "--data" && i + 1 < argc) {
            data = argv[++i];
        } else if (a == "--baseline" && i + 1 < argc) {
            baseline = argv[++i];
        } else if (a == "--runs" && i + 1 < argc) {
            runs = std::max(1, std::atoi(argv[++i]));
        } else if (a == "--tolerances" && i + 1 < argc) {
            tolerances.clear();
            for (const std::string& t : OIIO::Strutil::splits(argv[++i], ","))
                if (t != "none")
                    tolerances.push_back(std::stod(t));
        } else {
            std::fprintf(stderr,
                         "usage: bench_correct [--sizes 512,1024|none] [--budget S] [--out DIR] [--maps A,B] "
                         "[--data DIR] [--baseline OLD_RELIEF] [--runs N] [--tolerances T1,T2]\n");
            return 2;
        }
    }
    if (!baseline.empty() && access(baseline.c_str(), X_OK) != 0) {
        std::fprintf(stderr, "bench_correct: --baseline %s is not an executable\n", baseline.c_str());
        return 2;
    }
    std::filesystem::create_directories(out_dir);
    out_dir = std::filesystem::absolute(out_dir).string();
    if (!maps.empty())
        real_maps(maps, data, baseline, runs, tolerances, out_dir);
    if (sizes.empty())
        return 0;
    {  // warm the kernel cache
        correct(terrain(64), 0, 0, 1e-5);
    }
    std::ofstream md(out_dir + "/correct.md"), csv(out_dir + "/correct.csv");
    md << "| size | it/s per Mtexel | c2f converged (1e-5) s | c2f iterations (finest) | E0 | E* | c2f to 1% "
          "s | "
          "single-res to 1% s (iterations) | ratio | p95 anisotropy before -> after "
          "|\n|---|---|---|---|---|---|---|---|---|---|\n";
    csv << "size,iter_per_s_per_mtexel,c2f_converged_s,c2f_iterations,finest_iterations,e0,e_star,c2f_1pct_s,"
           "single_1pct_s,single_1pct_iterations,single_reached,p95_before,p95_after\n";
    for (int n : sizes) {
        const OIIO::ImageBuf h = terrain(n);
        // Iteration speed: single resolution, every tile, 2 vs 10 iterations.
        const Run two = correct(h, 1, 2, 1e-5, false), ten = correct(h, 1, 10, 1e-5, false);
        const double per_it = std::max(1e-9, (ten.seconds - two.seconds) / 8.0);
        const double ips = 1.0 / per_it / (double(n) * n / 1e6);
        // Coarse to fine: converged as shipped, and the reference optimum.
        const Run c2f = correct(h, 0, 0, 1e-5);
        const Run best = correct(h, 0, 0, 1e-6);
        const double e0 = c2f.energy_before, estar = std::min(best.energy, c2f.energy);
        const double target = estar + 0.01 * (e0 - estar);
        // Coarse to fine to 1%: the loosest tolerance that gets there.
        double c2f_1 = c2f.seconds;
        for (double tol : {1e-3, 3e-4, 1e-4, 3e-5}) {
            const Run r = correct(h, 0, 0, tol);
            if (r.energy <= target) {
                c2f_1 = r.seconds;
                break;
            }
        }
        // Single resolution to 1%: doubling iteration counts within the budget.
        double single_1 = -1, spent = 0;
        int single_it = 0;
        bool reached = false;
        for (int it = 8; spent < budget; it *= 2) {
            const Run r = correct(h, 1, it, 1e-5);
            spent += r.seconds;
            single_1 = r.seconds;
            single_it = it;
            std::fprintf(
                stderr,
                "bench_correct: %d^2 single resolution, %d iterations: %.2f s, E %.6g (target %.6g)\n", n, it,
                r.seconds, r.energy, target);
            if (r.energy <= target) {
                reached = true;
                break;
            }
        }
        const double ratio = single_1 / c2f_1;
        const auto& fin = c2f.report.levels.back();
        std::printf("%d^2: %.2f it/s/Mtexel; c2f converged %.2f s (%d iterations, %d at the finest); to 1%%: "
                    "c2f %.2f s, "
                    "single %s%.2f s (%d iterations); ratio %s%.1f; p95 anisotropy %.3f -> %.3f\n",
                    n, ips, c2f.seconds, c2f.iterations, fin.iterations, c2f_1, reached ? "" : "> ", single_1,
                    single_it, reached ? "" : ">= ", ratio, c2f.report.anisotropy_before.p95,
                    c2f.report.anisotropy_after.p95);
        std::fflush(stdout);
        char line[512];
        std::snprintf(
            line, sizeof line,
            "| %d² | %.2f | %.2f | %d (%d) | %.6g | %.6g | %.2f | %s%.2f (%d) | %s%.1f× | %.3f → %.3f |\n", n,
            ips, c2f.seconds, c2f.iterations, fin.iterations, e0, estar, c2f_1, reached ? "" : "> ", single_1,
            single_it, reached ? "" : "≥ ", ratio, c2f.report.anisotropy_before.p95,
            c2f.report.anisotropy_after.p95);
        md << line;
        csv << n << ',' << ips << ',' << c2f.seconds << ',' << c2f.iterations << ',' << fin.iterations << ','
            << e0 << ',' << estar << ',' << c2f_1 << ',' << single_1 << ',' << single_it << ',' << reached
            << ',' << c2f.report.anisotropy_before.p95 << ',' << c2f.report.anisotropy_after.p95 << '\n';
        md.flush();
        csv.flush();

        if (n == sizes.front()) {
            // Before | after anisotropy (1 black .. 2.5 white) | checker baked through the offsets.
            const auto before = anisotropy(h, nullptr, 0.05), after = anisotropy(h, &c2f.offsets, 0.05);
            OIIO::ImageBuf checker(OIIO::ImageSpec(n, n, 1, OIIO::TypeDesc::FLOAT));
            const float dark[1] = {0.1f}, light[1] = {0.9f};
            OIIO::ImageBufAlgo::checker(checker, n / 32, n / 32, 1, dark, light);
            relief::BakeOptions bo;
            bo.colorspace = relief::BakeColorspace::Raw;
            OIIO::ImageBuf baked = relief::bake(checker, c2f.offsets, bo);
            std::vector<float> ck(std::size_t(n) * n);
            baked.get_pixels(baked.roi(), OIIO::TypeDesc::FLOAT, ck.data());
            OIIO::ImageBuf pic(OIIO::ImageSpec(3 * n, n, 1, OIIO::TypeDesc::FLOAT));
            for (int y = 0; y < n; ++y)
                for (int x = 0; x < n; ++x) {
                    const std::size_t p = std::size_t(y) * n + x;
                    const float b = std::clamp((before[p] - 1.0f) / 1.5f, 0.0f, 1.0f);
                    const float a = std::clamp((after[p] - 1.0f) / 1.5f, 0.0f, 1.0f);
                    pic.setpixel(x, y, &b);
                    pic.setpixel(n + x, y, &a);
                    pic.setpixel(2 * n + x, y, &ck[p]);
                }
            pic.write(out_dir + "/correct_before_after.png", OIIO::TypeDesc::UINT8);
        }
    }
    return 0;
}
