// SPDX-License-Identifier: Apache-2.0
// boundary=auto against the best of the four per-axis boundaries
// (docs/design.md §4.4.3).
//
//   bench_boundary [--out bench/results] [--no-real]
//
// Each case is integrated by least squares under x and y each periodic or
// free, and scored against its true height by the NRMSE after the best
// affine fit (scale and offset of a height are arbitrary). A rule "hits" a
// case when the boundary it picks scores within 5% (or 0.005) of the best
// of the four. Two rules are set side by side: the per-axis rule of
// host/poisson/tiling.h (slope correlation and block heights), and the slope test
// alone with one choice for both axes (periodic when both axes pass).
// Cases:
//   shared   the real maps of ../shared/data against their authored heights
//   synthetic power-law fields (spectral exponents 2.5, 3, 3.5): a tiling
//            map (its normals 8-bit), one whose seam slopes are noise (a
//            seam painted over), one whose seam skips a texel, one that
//            tiles along x only, and a crop of a four times larger map
// Also the crops of the two real terrains (40 each, 40-70% of a side, at
// random places): how many of their axes the rule calls periodic (none
// should be: a crop of terrain does not tile).
// Writes boundary.csv (one row per case) and boundary.md into --out.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "image_files.h"
#include "relief/relief.h"
#include "support/accuracy.h"
#include "support/fields.h"
#include "poisson/tiling.h"

namespace fs = std::filesystem;
using OIIO::ImageBuf;

namespace {

using bench::channel;

struct Case {
    std::string group, name;
    ImageBuf normals;
    relief::NormalDecoding decoding;
    std::vector<float> truth;
};

// The four solves and both rules' choices for one case.
struct Verdict {
    double err[2][2] = {};  // [x periodic][y periodic]
    relief::host::TilingEvidence evidence;

    double best() const { return std::min({err[0][0], err[0][1], err[1][0], err[1][1]}); }
    double per_axis() const { return err[evidence.x.tiles][evidence.y.tiles]; }
    double released() const { return err[evidence.tiles][evidence.tiles]; }
    static bool hit(double e, double best) { return e <= std::max(1.05 * best, best + 0.005); }
};

relief::host::TilingEvidence evidence_of(const ImageBuf& normals, const relief::NormalDecoding& d)
{
    relief::SlopeOptions o;
    o.normals = d;
    const ImageBuf s = relief::slopes(normals, o);
    if (s.has_error()) {
        std::fprintf(stderr, "bench_boundary: %s\n", s.geterror().c_str());
        std::exit(1);
    }
    std::vector<float> g(std::size_t(s.spec().width) * s.spec().height * 2);
    s.get_pixels(s.roi(), OIIO::TypeDesc::FLOAT, g.data());
    return relief::host::tiling_evidence(g.data(), s.spec().width, s.spec().height);
}

Verdict judge(const Case& c)
{
    Verdict v;
    for (int px = 0; px < 2; ++px)
        for (int py = 0; py < 2; ++py) {
            relief::HeightOptions o;
            o.normals = c.decoding;
            o.method = relief::HeightMethod::Poisson;
            o.boundary = relief::Boundaries(px ? relief::Boundary::Periodic : relief::Boundary::Free,
                                            py ? relief::Boundary::Periodic : relief::Boundary::Free);
            const ImageBuf h = relief::height(c.normals, o);
            if (h.has_error()) {
                std::fprintf(stderr, "bench_boundary: %s: %s\n", c.name.c_str(), h.geterror().c_str());
                std::exit(1);
            }
            v.err[px][py] = relief::test::nrmse_affine_std(channel(h, 0), c.truth);
        }
    v.evidence = evidence_of(c.normals, c.decoding);
    return v;
}

// A power-law height field, periodic over px x py texels, sampled on the
// w x h texels from (x0, y0): heights and exact slopes.
struct Field {
    std::vector<float> h;
    std::vector<double> g;
};

Field power_law(int px, int py, int x0, int y0, int w, int h, double beta, unsigned seed)
{
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal;
    struct W {
        int kx, ky;
        double a, phase;
    };
    std::vector<W> waves;
    const int kmax = std::max(px, py) / 4;
    std::uniform_int_distribution<int> kx(-kmax, kmax), ky(0, kmax);
    std::uniform_real_distribution<double> phase(0.0, 2 * M_PI);
    // Every wave up to 12 cycles across the longer side (where a power law
    // puts most of the height), then 240 drawn at random up to a quarter of
    // the texels.
    auto add = [&](int a, int b) {
        const double k = std::hypot(double(a) / px, double(b) / py) * std::max(px, py);
        waves.push_back({a, b, normal(rng) * std::pow(k, -beta / 2), phase(rng)});
    };
    const int low = 12;
    for (int b = 0; b <= low * py / std::max(px, py); ++b)
        for (int a = -low * px / std::max(px, py); a <= low * px / std::max(px, py); ++a)
            if (!(b == 0 && a <= 0) && std::hypot(double(a) / px, double(b) / py) * std::max(px, py) <= low)
                add(a, b);
    for (int drawn = 0; drawn < 240;) {
        const int a = kx(rng), b = ky(rng);
        if ((b == 0 && a <= 0) || std::hypot(double(a) / px, double(b) / py) * std::max(px, py) <= low)
            continue;
        add(a, b);
        ++drawn;
    }
    Field f;
    f.h.resize(std::size_t(w) * h);
    f.g.resize(2 * f.h.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double v = 0, gx = 0, gy = 0;
            for (const W& q : waves) {
                const double wx = 2 * M_PI * q.kx / px, wy = 2 * M_PI * q.ky / py;
                const double t = wx * (x + x0) + wy * (y + y0) + q.phase;
                v += q.a * std::sin(t);
                gx += q.a * wx * std::cos(t);
                gy += q.a * wy * std::cos(t);
            }
            const std::size_t i = std::size_t(y) * w + x;
            f.h[i] = float(v);
            f.g[2 * i] = gx;
            f.g[2 * i + 1] = gy;
        }
    // Scale to slopes of rms 0.5 (normals tilted by about 27 degrees).
    double s = 0;
    for (double v : f.g)
        s += v * v;
    const double k = 0.5 / std::sqrt(s / double(f.h.size()));
    for (double& v : f.g)
        v *= k;
    for (float& v : f.h)
        v = float(v * k);
    return f;
}

Case synthetic(const std::string& name, const Field& f, int w, int h, OIIO::TypeDesc type)
{
    Case c;
    c.group = "synthetic";
    c.name = name;
    c.normals = relief::test::normal_image(f.g, w, h, relief::test::Green::OpenGL, type);
    c.decoding.convention = relief::NormalConvention::OpenGL;
    c.truth = f.h;
    return c;
}

std::vector<Case> synthetic_cases()
{
    std::vector<Case> cases;
    const int n = 256;
    unsigned seed = 11;
    for (double beta : {2.5, 3.0, 3.5}) {
        char b[16];
        std::snprintf(b, sizeof b, "%.1f", beta);
        const std::string tag = std::string(" beta ") + b;
        const Field tile = power_law(n, n, 0, 0, n, n, beta, ++seed);
        cases.push_back(synthetic("tiles, 8-bit normals" + tag, tile, n, n, OIIO::TypeDesc::UINT8));
        // The seam's two columns and rows painted over: their slopes are
        // noise of the same strength.
        Field rough = tile;
        std::mt19937 rng(seed);
        std::normal_distribution<double> normal(0.0, 0.5 / std::sqrt(2.0));
        for (int i = 0; i < n; ++i)
            for (int e : {0, n - 1})
                for (int c = 0; c < 2; ++c) {
                    rough.g[2 * (std::size_t(i) * n + e) + c] = normal(rng);
                    rough.g[2 * (std::size_t(e) * n + i) + c] = normal(rng);
                }
        cases.push_back(synthetic("tiles, seam painted over" + tag, rough, n, n, OIIO::TypeDesc::FLOAT));
        // Periodic over n + 1 columns, n of them kept: the seam skips one.
        cases.push_back(synthetic("tiles, seam skips a texel" + tag,
                                  power_law(n + 1, n, 0, 0, n, n, beta, ++seed), n, n,
                                  OIIO::TypeDesc::FLOAT));
        // Periodic along x; y holds half of a period twice as long.
        cases.push_back(synthetic("tiles along x only" + tag,
                                  power_law(n, 2 * n, 0, n / 3, n, n, beta, ++seed), n, n,
                                  OIIO::TypeDesc::FLOAT));
        cases.push_back(synthetic("crop of a 4x larger map" + tag,
                                  power_law(4 * n, 4 * n, n, n, n, n, beta, ++seed), n, n,
                                  OIIO::TypeDesc::FLOAT));
    }
    // Brick walls, 2:1, tiling along x only, 8-bit normals (the held-back
    // map the per-axis rule called periodic along y, 0.52 against 0.11).
    for (const auto& [bw, bh, y0] : {std::tuple{64, 16, 5}, std::tuple{32, 12, 0}, std::tuple{128, 24, 9}}) {
        const int w = 256, h = 128;
        const relief::test::BrickWall wall = relief::test::brick_wall(w, h, bw, bh, y0, ++seed);
        Field f{wall.h, wall.g};
        cases.push_back(
            synthetic("brick wall " + std::to_string(bw) + "x" + std::to_string(bh) + ", 2:1, tiles along x",
                      f, w, h, OIIO::TypeDesc::UINT8));
    }
    return cases;
}

// The shared maps with their authored heights; the green convention is
// relief's own guess, as a user would get it.
std::vector<Case> shared_cases(const fs::path& root)
{
    std::vector<Case> cases;
    if (!fs::is_directory(root))
        return cases;
    for (const fs::path& s : bench::map_folders(root)) {
        Case c;
        c.group = "shared";
        c.name = s.filename().string();
        c.normals = ImageBuf((s / "normal.png").string());
        ImageBuf height((s / "height.png").string());
        if (!c.normals.read(0, 0, true, OIIO::TypeDesc::FLOAT) ||
            !height.read(0, 0, true, OIIO::TypeDesc::FLOAT)) {
            std::fprintf(stderr, "bench_boundary: cannot read %s\n", s.c_str());
            std::exit(1);
        }
        c.truth = channel(height, 0);
        cases.push_back(std::move(c));
    }
    return cases;
}

// Crops of the real terrains (40-70% of each side, random places): the
// number of axes the per-axis rule calls periodic, of all axes judged.
std::pair<int, int> terrain_crops(const fs::path& root, std::FILE* md)
{
    int periodic = 0, axes = 0;
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> part(0.4, 0.7);
    for (const char* name : {"dem_jacksboro", "dem_etopo5_himalaya"}) {
        ImageBuf n((root / name / "normal.png").string());
        if (!n.read(0, 0, true, OIIO::TypeDesc::FLOAT))
            continue;
        const int W = n.spec().width, H = n.spec().height;
        for (int t = 0; t < 40; ++t) {
            const int w = int(W * part(rng)), h = int(H * part(rng));
            const int x = std::uniform_int_distribution<int>(0, W - w)(rng);
            const int y = std::uniform_int_distribution<int>(0, H - h)(rng);
            ImageBuf crop;
            OIIO::ImageBufAlgo::cut(crop, n, OIIO::ROI(x, x + w, y, y + h));
            const relief::host::TilingEvidence e = evidence_of(crop, {});
            periodic += e.x.tiles + e.y.tiles;
            axes += 2;
            if (e.x.tiles || e.y.tiles)
                std::fprintf(md, "- %s crop %dx%d+%d+%d called periodic along %s\n", name, w, h, x, y,
                             e.x.tiles ? (e.y.tiles ? "x and y" : "x") : "y");
        }
    }
    return {periodic, axes};
}

const char* word(bool periodic)
{
    return periodic ? "periodic" : "free";
}

}  // namespace

int main(int argc, char** argv)
{
    fs::path out = "bench/results";
    bool real = true;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--out") && i + 1 < argc)
            out = argv[++i];
        else if (!std::strcmp(argv[i], "--no-real"))
            real = false;
        else {
            std::fprintf(stderr, "usage: bench_boundary [--out DIR] [--no-real]\n");
            return 2;
        }
    }
    fs::create_directories(out);
    const fs::path shared = RELIEF_SHARED_DATA;
    std::vector<Case> cases = real ? shared_cases(shared) : std::vector<Case>{};
    for (Case& c : synthetic_cases())
        cases.push_back(std::move(c));

    std::ofstream csv(out / "boundary.csv");
    csv << "group,case,free_free,periodic_free,free_periodic,periodic_periodic,x_seam_r,x_adjacent_r,x_"
           "height_"
           "step,y_seam_r,y_adjacent_r,y_height_step,per_axis,per_axis_hit,released,released_hit\n";
    std::FILE* md = std::fopen((out / "boundary.md").c_str(), "w");
    std::fprintf(md, "# boundary=auto against the best of four per-axis boundaries\n\n"
                     "Made by `build/bench/bench_boundary` (bench/bench_boundary.cpp). NRMSE after the best "
                     "affine fit against the true height; a hit is within 5%% (or 0.005) of the best of the "
                     "four. Evidence per axis: slope |r| across the seam / between neighbours, block-height "
                     "step across the seam / between neighbours.\n\n"
                     "| case | best | per-axis auto | slopes alone, both axes | x: r seam/adj, step | y: r "
                     "seam/adj, step |\n|---|---|---|---|---|---|\n");
    struct Tally {
        int n = 0, per_axis = 0, released = 0;
    };
    std::vector<std::pair<std::string, Tally>> tallies;
    for (const Case& c : cases) {
        const Verdict v = judge(c);
        const auto& e = v.evidence;
        const bool hit = Verdict::hit(v.per_axis(), v.best()), old = Verdict::hit(v.released(), v.best());
        int bx = 0, by = 0;
        for (int px = 0; px < 2; ++px)
            for (int py = 0; py < 2; ++py)
                if (v.err[px][py] == v.best()) {
                    bx = px;
                    by = py;
                }
        std::fprintf(
            md, "| %s | %s,%s %.3f | %s,%s %.3f%s | %s %.3f%s | %.2f/%.2f, %.2f | %.2f/%.2f, %.2f |\n",
            c.name.c_str(), word(bx), word(by), v.best(), word(e.x.tiles), word(e.y.tiles), v.per_axis(),
            hit ? "" : " **miss**", word(e.tiles), v.released(), old ? "" : " **miss**", e.x.seam,
            e.x.adjacent, e.x.height_step, e.y.seam, e.y.adjacent, e.y.height_step);
        csv << c.group << ',' << c.name << ',' << v.err[0][0] << ',' << v.err[1][0] << ',' << v.err[0][1]
            << ',' << v.err[1][1] << ',' << e.x.seam << ',' << e.x.adjacent << ',' << e.x.height_step << ','
            << e.y.seam << ',' << e.y.adjacent << ',' << e.y.height_step << ',' << word(e.x.tiles) << '/'
            << word(e.y.tiles) << ',' << hit << ',' << word(e.tiles) << ',' << old << '\n';
        auto it =
            std::find_if(tallies.begin(), tallies.end(), [&](const auto& t) { return t.first == c.group; });
        if (it == tallies.end())
            it = tallies.insert(tallies.end(), {c.group, {}});
        it->second.n++;
        it->second.per_axis += hit;
        it->second.released += old;
        std::printf("%-10s %-40s per-axis %s  slopes alone %s\n", c.group.c_str(), c.name.c_str(),
                    hit ? "hit " : "MISS", old ? "hit" : "MISS");
        std::fflush(stdout);
    }
    std::fprintf(md, "\n| cases | per-axis auto hits | slopes alone hits |\n|---|---|---|\n");
    for (const auto& [group, t] : tallies)
        std::fprintf(md, "| %s (%d) | %d | %d |\n", group.c_str(), t.n, t.per_axis, t.released);
    if (real) {
        std::fprintf(md, "\nCrops of the real terrains:\n\n");
        const auto [periodic, axes] = terrain_crops(shared, md);
        std::fprintf(md, "- %d of %d axes called periodic (a crop of terrain should be free)\n", periodic,
                     axes);
        std::printf("terrain crops: %d of %d axes called periodic\n", periodic, axes);
    }
    std::fclose(md);
    std::printf("bench_boundary: wrote %s and %s\n", (out / "boundary.md").c_str(),
                (out / "boundary.csv").c_str());
    return 0;
}
