// SPDX-License-Identifier: Apache-2.0
// Run time against error over many real maps: every method and boundary
// relief offers, on every map of one or more data folders (the corpus that
// scripts/corpus builds, the maintainers' shared maps), scored against the
// heights the maps' authors made.
//
//   bench_corpus --data DIR [--data DIR ...] [--out bench/results]
//                [--radii 16,64,256] [--only SUBSTRING]
//
// A data folder holds one folder per map with normal.png and height.png
// (and meta.json: package and kind, else the folder's name stands for the
// package). Per map, heights by:
//   poisson   least squares under each of the four per-axis boundaries
//   rays      fast rays at each radius, clip and periodic
//   default   what relief does without options (method and boundary auto)
// each scored by the NRMSE after the best affine fit (std-normalised:
// tests/support/accuracy.h) and timed (the whole height() call, kernels
// warm: each run is made twice and the second timed). The green convention is
// relief's own guess, as a user would get it. Per map also the evidence a
// rule could go on, from the normals alone: the tiling test's numbers per
// axis, and of the default's height the share of its variance at scales
// above each radius, the slopes' kurtosis and the share of nearly flat
// texels (bricks and planks: flat faces between sharp steps).
// Writes corpus_runs.csv (one row per map and run) and corpus_maps.csv (one
// row per map: the evidence) into --out; bench/corpus_rules.py reads them.
#include <OpenImageIO/imagebuf.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "poisson/tiling.h"
#include "image_files.h"
#include "relief/relief.h"
#include "support/accuracy.h"

namespace fs = std::filesystem;
using OIIO::ImageBuf;

namespace {

using bench::channel;

[[noreturn]] void die(const std::string& what)
{
    std::fprintf(stderr, "bench_corpus: %s\n", what.c_str());
    std::exit(1);
}

struct Map {
    std::string name, package, kind;
    ImageBuf normals;
    std::vector<float> truth;
    int width = 0, height = 0;
};

std::vector<Map> read_maps(const std::vector<fs::path>& folders, const std::string& only)
{
    std::vector<Map> maps;
    for (const fs::path& root : folders) {
        if (!fs::is_directory(root))
            die("no data folder " + root.string());
        for (const fs::path& s : bench::map_folders(root)) {
            Map m;
            m.name = s.filename().string();
            if (!only.empty() && m.name.find(only) == std::string::npos)
                continue;
            m.package = root.filename().string();
            m.kind = "?";
            std::ifstream meta(s / "meta.json");
            if (meta) {
                const nlohmann::json j = nlohmann::json::parse(meta, nullptr, false);
                if (j.is_object()) {
                    m.package = j.value("package", m.package);
                    m.kind = j.value("kind", m.kind);
                    if (m.kind == "?" && m.name.rfind("dem_", 0) == 0)
                        m.kind = "dem";
                }
            }
            m.normals = ImageBuf((s / "normal.png").string());
            ImageBuf height((s / "height.png").string());
            if (!m.normals.read(0, 0, true, OIIO::TypeDesc::FLOAT) ||
                !height.read(0, 0, true, OIIO::TypeDesc::FLOAT))
                die("cannot read " + s.string());
            m.width = m.normals.spec().width;
            m.height = m.normals.spec().height;
            m.truth = channel(height, 0);
            maps.push_back(std::move(m));
        }
    }
    return maps;
}

struct Run {
    std::string method, boundary;
    float radius = 0.0f;
    double nrmse = 0.0, seconds = 0.0;
    std::vector<float> h;
};

Run run(const Map& m, const relief::HeightOptions& o, const std::string& method, const std::string& boundary)
{
    Run r;
    r.method = method;
    r.boundary = boundary;
    r.radius = o.method == relief::HeightMethod::Rays ? o.radius : 0.0f;
    // Twice, the second timed: its kernels and plans are warm, as in a
    // farm's second map of a size.
    if (relief::height(m.normals, o).has_error())
        die(m.name + ": " + relief::geterror());
    const auto t0 = std::chrono::steady_clock::now();
    const ImageBuf h = relief::height(m.normals, o);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (h.has_error())
        die(m.name + ": " + h.geterror());
    r.h = channel(h, 0);
    r.nrmse = relief::test::nrmse_affine_std(r.h, m.truth);
    return r;
}

// A box mean over (2r+1)^2 texels, edges clamped: separable running sums.
std::vector<double> box_mean(const std::vector<float>& v, int w, int h, int r)
{
    std::vector<double> a(v.begin(), v.end()), b(a.size());
    auto pass = [&](const std::vector<double>& in, std::vector<double>& out, int n, int lines,
                    std::size_t step, std::size_t line_step) {
        for (int l = 0; l < lines; ++l) {
            const std::size_t base = std::size_t(l) * line_step;
            auto at = [&](int i) { return in[base + std::size_t(std::clamp(i, 0, n - 1)) * step]; };
            double s = 0;
            for (int i = -r; i <= r; ++i)
                s += at(i);
            for (int i = 0; i < n; ++i) {
                out[base + std::size_t(i) * step] = s / (2 * r + 1);
                s += at(i + r + 1) - at(i - r);
            }
        }
    };
    pass(a, b, w, h, 1, std::size_t(w));
    pass(b, a, h, w, std::size_t(w), 1);
    return a;
}

// The share of a height's variance at scales above r texels.
double coarse_share(const std::vector<float>& height, int w, int h, int r)
{
    const std::vector<double> low = box_mean(height, w, h, r);
    double mh = 0, ml = 0;
    for (std::size_t i = 0; i < low.size(); ++i)
        mh += height[i], ml += low[i];
    mh /= double(low.size()), ml /= double(low.size());
    double vh = 0, vl = 0;
    for (std::size_t i = 0; i < low.size(); ++i)
        vh += (height[i] - mh) * (height[i] - mh), vl += (low[i] - ml) * (low[i] - ml);
    return vh > 0 ? vl / vh : 0.0;
}

struct SlopeStats {
    double kurtosis = 0.0, flat = 0.0;
    relief::host::TilingEvidence tiling;
};

SlopeStats slope_stats(const Map& m)
{
    const ImageBuf s = relief::slopes(m.normals, relief::SlopeOptions{});
    if (s.has_error())
        die(m.name + ": " + s.geterror());
    std::vector<float> g(std::size_t(m.width) * m.height * 2);
    s.get_pixels(s.roi(), OIIO::TypeDesc::FLOAT, g.data());
    SlopeStats st;
    st.tiling = relief::host::tiling_evidence(g.data(), m.width, m.height);
    // Kurtosis of each component (4th moment over the squared 2nd), and
    // the share of texels whose slope is under a tenth of the rms.
    double m2 = 0, m4 = 0;
    const std::size_t n = g.size();
    for (float v : g)
        m2 += double(v) * v, m4 += double(v) * v * v * v;
    m2 /= double(n), m4 /= double(n);
    st.kurtosis = m2 > 0 ? m4 / (m2 * m2) : 0.0;
    const double rms = std::sqrt(m2);
    std::size_t flat = 0;
    for (std::size_t i = 0; i < n; i += 2)
        flat += std::hypot(g[i], g[i + 1]) < 0.1 * rms;
    st.flat = double(flat) / double(n / 2);
    return st;
}

std::vector<float> parse_radii(const char* s)
{
    std::vector<float> out;
    for (const char* p = s; *p;) {
        char* end = nullptr;
        const float v = std::strtof(p, &end);
        if (end == p || v <= 0)
            die(std::string("--radii: not a list of positive numbers: ") + s);
        out.push_back(v);
        p = *end == ',' ? end + 1 : end;
    }
    return out;
}

}  // namespace

int main(int argc, char** argv)
{
    std::vector<fs::path> data;
    fs::path out = "bench/results";
    std::vector<float> radii = {16.0f, 64.0f, 256.0f};
    std::string only;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--data" && i + 1 < argc)
            data.emplace_back(argv[++i]);
        else if (a == "--out" && i + 1 < argc)
            out = argv[++i];
        else if (a == "--radii" && i + 1 < argc)
            radii = parse_radii(argv[++i]);
        else if (a == "--only" && i + 1 < argc)
            only = argv[++i];
        else
            die("usage: bench_corpus --data DIR [--data DIR ...] [--out DIR] [--radii 16,64,256] [--only "
                "TEXT]");
    }
    if (data.empty())
        die("give at least one --data folder (scripts/corpus builds one)");
    const std::vector<Map> maps = read_maps(data, only);
    fs::create_directories(out);
    std::FILE* runs = std::fopen((out / "corpus_runs.csv").c_str(), "w");
    std::FILE* feats = std::fopen((out / "corpus_maps.csv").c_str(), "w");
    if (!runs || !feats)
        die("cannot write into " + out.string());
    std::fprintf(runs, "map,package,kind,width,height,method,boundary,radius,nrmse,seconds\n");
    std::fprintf(
        feats,
        "map,package,kind,width,height,default_method,default_boundary,x_seam,x_adjacent,x_slopes_tile,"
        "x_height_step,x_tiles,y_seam,y_adjacent,y_slopes_tile,y_height_step,y_tiles,slope_kurtosis,"
        "flat_share");
    for (float r : radii)
        std::fprintf(feats, ",coarse_share_%g", r);
    std::fprintf(feats, "\n");
    const char* side[2] = {"free", "periodic"};
    int done = 0;
    for (const Map& m : maps) {
        std::vector<Run> rs;
        relief::HeightOptions base;
        relief::HeightReport report;
        base.report = &report;
        rs.push_back(run(m, base, "default", "auto"));
        const std::string default_method = report.method, default_boundary = report.boundary;
        base.report = nullptr;
        for (int px = 0; px < 2; ++px)
            for (int py = 0; py < 2; ++py) {
                relief::HeightOptions o = base;
                o.method = relief::HeightMethod::Poisson;
                o.boundary = relief::Boundaries(px ? relief::Boundary::Periodic : relief::Boundary::Free,
                                                py ? relief::Boundary::Periodic : relief::Boundary::Free);
                rs.push_back(run(m, o, "poisson", std::string(side[px]) + "," + side[py]));
            }
        for (float r : radii)
            for (int p = 0; p < 2; ++p) {
                relief::HeightOptions o = base;
                o.method = relief::HeightMethod::Rays;
                o.radius = r;
                o.boundary = p ? relief::Boundary::Periodic : relief::Boundary::Free;
                rs.push_back(run(m, o, "rays", p ? "periodic" : "clip"));
            }
        for (const Run& r : rs)
            std::fprintf(runs, "%s,%s,%s,%d,%d,%s,\"%s\",%g,%.5f,%.4f\n", m.name.c_str(), m.package.c_str(),
                         m.kind.c_str(), m.width, m.height, r.method.c_str(), r.boundary.c_str(), r.radius,
                         r.nrmse, r.seconds);
        const SlopeStats st = slope_stats(m);
        const auto axis = [&](const relief::host::AxisEvidence& a) {
            std::fprintf(feats, ",%.4f,%.4f,%d,%.4f,%d", a.seam, a.adjacent, int(a.slopes_tile),
                         a.height_step, int(a.tiles));
        };
        std::fprintf(feats, "%s,%s,%s,%d,%d,%s,\"%s\"", m.name.c_str(), m.package.c_str(), m.kind.c_str(),
                     m.width, m.height, default_method.c_str(), default_boundary.c_str());
        axis(st.tiling.x);
        axis(st.tiling.y);
        std::fprintf(feats, ",%.4f,%.4f", st.kurtosis, st.flat);
        for (float r : radii)
            std::fprintf(feats, ",%.4f", coarse_share(rs[0].h, m.width, m.height, int(r)));
        std::fprintf(feats, "\n");
        std::fflush(runs);
        std::fflush(feats);
        const auto best = std::min_element(rs.begin(), rs.end(),
                                           [](const Run& a, const Run& b) { return a.nrmse < b.nrmse; });
        std::fprintf(stderr, "bench_corpus: %d/%zu %s: default %.3f, best %.3f (%s %s %g)\n", ++done,
                     maps.size(), m.name.c_str(), rs[0].nrmse, best->nrmse, best->method.c_str(),
                     best->boundary.c_str(), best->radius);
    }
    std::fclose(runs);
    std::fclose(feats);
    return 0;
}
