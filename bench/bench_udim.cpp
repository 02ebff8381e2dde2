// SPDX-License-Identifier: Apache-2.0
// UDIM sets solved tile by tile and as one surface (docs/design.md §4.4.4).
//
//   bench_udim [--out bench/results] [--runs N]
//
// Each tiling map of the shared data that is at least 1024 texels a side is
// cut into four UDIM tiles (1011 1012 above 1001 1002) and integrated by
// relief::height_udim under udim=each, joint and auto (the default), every
// other option at its default. Against the whole map's own solve (same
// options) it measures:
//   distance  rms of (tiles - whole map's solve), over the whole's std
//   border    mean |step| between neighbouring texels across the tile
//             borders, over the mean |step| between neighbouring texels
//             elsewhere (1 = no seam)
//   seconds   median of --runs runs (default 3)
// Then tile 1012 of 0ad_paving_india is replaced by gk_castell_wall_v01's
// normals (an unrelated map of the same size): the edges auto joins and
// cuts, the replaced tile against its own single run, and the border ratio
// of the three remaining tiles.
// Writes udim.csv, udim.md and udim_before_after.png (nx_brickfloor's
// heights under each and auto, each panel scaled to its own range) into
// --out.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "relief/relief.h"
#include "relief/udim.h"

namespace fs = std::filesystem;
using OIIO::ImageBuf;
using OIIO::ROI;

namespace {

// A map's normals cut into a 2 x 2 set: tiles[0..3] are 1001, 1002, 1011,
// 1012; v up, so 1011 and 1012 are the image's top half.
struct Set {
    std::string name;
    ImageBuf whole;
    ImageBuf tiles[4];
    int tw = 0, th = 0;
    relief::NormalConvention convention = relief::NormalConvention::Auto;

    std::vector<relief::UdimTile> udim() const
    {
        return {{1001, &tiles[0]}, {1002, &tiles[1]}, {1011, &tiles[2]}, {1012, &tiles[3]}};
    }
};

// The tile's place in the whole image: its column and row of tiles.
ROI tile_roi(int i, int tw, int th)
{
    const int u = i % 2, row = 1 - i / 2;  // v up: v = 1 is the top row of tiles
    return ROI(u * tw, (u + 1) * tw, row * th, (row + 1) * th);
}

Set cut_set(const std::string& name, const ImageBuf& normals, relief::NormalConvention convention)
{
    Set s;
    s.name = name;
    s.whole.copy(normals);
    s.tw = normals.spec().width / 2;
    s.th = normals.spec().height / 2;
    s.convention = convention;
    for (int i = 0; i < 4; ++i)
        OIIO::ImageBufAlgo::cut(s.tiles[i], normals, tile_roi(i, s.tw, s.th));
    return s;
}

std::vector<float> pixels(const ImageBuf& b)
{
    std::vector<float> v(std::size_t(b.spec().width) * b.spec().height);
    ROI r = b.roi();
    r.chend = r.chbegin + 1;
    b.get_pixels(r, OIIO::TypeDesc::FLOAT, v.data());
    return v;
}

// The tiles' heights laid back into one w x h image.
std::vector<float> assemble(const std::vector<ImageBuf>& tiles, int tw, int th)
{
    std::vector<float> out(std::size_t(2 * tw) * 2 * th);
    for (int i = 0; i < 4; ++i) {
        const std::vector<float> t = pixels(tiles[i]);
        const ROI r = tile_roi(i, tw, th);
        for (int y = 0; y < th; ++y)
            std::copy_n(t.begin() + std::size_t(y) * tw, tw,
                        out.begin() + std::size_t(r.ybegin + y) * 2 * tw + r.xbegin);
    }
    return out;
}

double spread(const std::vector<float>& v)
{
    double m = 0, s = 0;
    for (float x : v)
        m += x;
    m /= double(v.size());
    for (float x : v)
        s += (x - m) * (x - m);
    return std::sqrt(s / double(v.size()));
}

double rms_distance(const std::vector<float>& a, const std::vector<float>& b)
{
    double s = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        s += double(a[i] - b[i]) * (a[i] - b[i]);
    return std::sqrt(s / double(a.size()));
}

// Mean |step| across the borders x = tw and y = th, over the mean |step|
// between other neighbours; pairs of tiles `skip` names (a tile index,
// -1 for none) are left out.
double border_ratio(const std::vector<float>& h, int tw, int th, int skip = -1)
{
    const int w = 2 * tw, ht = 2 * th;
    const auto tile_of = [&](int x, int y) { return (x >= tw) + 2 * (y < th); };
    double border = 0, inside = 0;
    long nb = 0, ni = 0;
    const auto add = [&](int x0, int y0, int x1, int y1) {
        const int a = tile_of(x0, y0), b = tile_of(x1, y1);
        if (a == skip || b == skip)
            return;
        const double d = std::abs(h[std::size_t(y1) * w + x1] - h[std::size_t(y0) * w + x0]);
        if (a != b) {
            border += d;
            ++nb;
        } else {
            inside += d;
            ++ni;
        }
    };
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x) {
            if (x + 1 < w)
                add(x, y, x + 1, y);
            if (y + 1 < ht)
                add(x, y, x, y + 1);
        }
    return (border / double(nb)) / (inside / double(ni));
}

relief::HeightOptions options_for(const Set& s, relief::UdimMode mode)
{
    relief::HeightOptions o;
    o.normals.convention = s.convention;
    o.udim = mode;
    return o;
}

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

// 8-bit grey: each panel scaled to its own range, side by side, shrunk to
// `side` texels high.
void write_picture(const fs::path& path, const std::vector<std::vector<float>>& panels, int w, int h,
                   int side)
{
    const int gap = 16, pw = side * w / h;
    ImageBuf sheet(OIIO::ImageSpec(int(panels.size()) * (pw + gap) - gap, side, 1, OIIO::TypeDesc::UINT8));
    OIIO::ImageBufAlgo::fill(sheet, {1.0f});
    for (std::size_t p = 0; p < panels.size(); ++p) {
        const auto [lo, hi] = std::minmax_element(panels[p].begin(), panels[p].end());
        std::vector<float> scaled(panels[p].size());
        for (std::size_t i = 0; i < scaled.size(); ++i)
            scaled[i] = (panels[p][i] - *lo) / std::max(1e-12f, *hi - *lo);
        ImageBuf full(OIIO::ImageSpec(w, h, 1, OIIO::TypeDesc::FLOAT), scaled.data());
        ImageBuf small;
        OIIO::ImageBufAlgo::resize(small, full, "", 0.0f, ROI(0, pw, 0, side));
        OIIO::ImageBufAlgo::paste(sheet, int(p) * (pw + gap), 0, 0, 0, small);
    }
    sheet.write(path.string());
}

}  // namespace

int main(int argc, char** argv)
{
    fs::path out = "bench/results";
    int runs = 3;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--out") && i + 1 < argc)
            out = argv[++i];
        else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = std::max(1, std::atoi(argv[++i]));
        else {
            std::fprintf(stderr, "usage: bench_udim [--out DIR] [--runs N]\n");
            return 2;
        }
    }
    const fs::path shared = RELIEF_SHARED_DATA;
    if (!fs::is_directory(shared)) {
        std::fprintf(stderr, "bench_udim: the shared data (%s) is missing\n", shared.c_str());
        return 1;
    }
    fs::create_directories(out);
    const auto read = [&](const std::string& name, ImageBuf& normals, relief::NormalConvention& c) {
        normals.reset((shared / name / "normal.png").string());
        std::ifstream meta(shared / name / "meta.json");
        const std::string text((std::istreambuf_iterator<char>(meta)), std::istreambuf_iterator<char>());
        c = text.find("\"green\": \"Y+") != std::string::npos ? relief::NormalConvention::OpenGL
                                                              : relief::NormalConvention::DirectX;
        return normals.read(0, 0, true);  // 8-bit stays 8-bit: float normals would be read as [-1, 1]
    };

    std::vector<Set> sets;
    std::vector<fs::path> names;
    for (const auto& e : fs::directory_iterator(shared))
        names.push_back(e.path());
    std::sort(names.begin(), names.end());
    for (const fs::path& p : names) {
        std::ifstream prov(p / "provenance.txt");
        const std::string text((std::istreambuf_iterator<char>(prov)), std::istreambuf_iterator<char>());
        if (text.find("tiling: yes") == std::string::npos)
            continue;
        ImageBuf n;
        relief::NormalConvention c;
        if (!read(p.filename().string(), n, c) || n.spec().width < 1024 || n.spec().height < 1024 ||
            n.spec().width % 2 || n.spec().height % 2)
            continue;
        sets.push_back(cut_set(p.filename().string(), n, c));
    }
    if (sets.empty()) {
        std::fprintf(stderr, "bench_udim: no tiling map of 1024 or more in %s\n", shared.c_str());
        return 1;
    }

    std::ofstream csv(out / "udim.csv");
    csv << "map,mode,distance,border,seconds\n";
    std::FILE* md = std::fopen((out / "udim.md").c_str(), "w");
    std::fprintf(
        md,
        "# UDIM sets: tile by tile against one surface\n\n"
        "Made by `build/bench/bench_udim` (bench/bench_udim.cpp). Each tiling map of the shared data "
        "(1024 or more a side) cut into four UDIM tiles and integrated with the default options "
        "under each udim mode. distance: rms of the tiles against the whole map's solve, over its "
        "std. border: mean |step| between neighbouring texels across the tile borders over the mean "
        "elsewhere (1: no seam). Seconds: median of %d runs on this machine (PoCL CPU).\n\n"
        "| map | mode | distance | border | seconds |\n|---|---|---|---|---|\n",
        runs);
    std::vector<std::vector<float>> picture;
    int picture_w = 0, picture_h = 0;
    for (const Set& s : sets) {
        const ImageBuf whole = relief::height(s.whole, options_for(s, relief::UdimMode::Each));
        if (whole.has_error()) {
            std::fprintf(stderr, "bench_udim: %s: %s\n", s.name.c_str(), relief::geterror().c_str());
            return 1;
        }
        const std::vector<float> want = pixels(whole);
        const double sd = spread(want);
        std::printf("%s: whole map border ratio %.3f\n", s.name.c_str(), border_ratio(want, s.tw, s.th));
        for (const auto& [mode, word] :
             {std::pair{relief::UdimMode::Each, "each"}, std::pair{relief::UdimMode::Joint, "joint"},
              std::pair{relief::UdimMode::Auto, "auto"}}) {
            std::vector<double> seconds;
            std::vector<ImageBuf> got;
            for (int r = 0; r < runs; ++r) {
                const auto t0 = std::chrono::steady_clock::now();
                if (!relief::height_udim(got, s.udim(), options_for(s, mode))) {
                    std::fprintf(stderr, "bench_udim: %s %s: %s\n", s.name.c_str(), word,
                                 relief::geterror().c_str());
                    return 1;
                }
                seconds.push_back(
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            }
            const std::vector<float> h = assemble(got, s.tw, s.th);
            const double distance = rms_distance(h, want) / sd, border = border_ratio(h, s.tw, s.th);
            std::printf("  %-5s distance %.4f border %.3f  %.2f s\n", word, distance, border,
                        median(seconds));
            csv << s.name << ',' << word << ',' << distance << ',' << border << ',' << median(seconds)
                << '\n';
            std::fprintf(md, "| %s | %s | %.4f | %.3f | %.2f |\n", s.name.c_str(), word, distance, border,
                         median(seconds));
            if (s.name == "nx_brickfloor" && mode != relief::UdimMode::Joint) {
                picture.push_back(h);
                picture_w = 2 * s.tw;
                picture_h = 2 * s.th;
            }
        }
    }

    // Tile 1012 replaced by an unrelated map.
    ImageBuf other;
    relief::NormalConvention other_c;
    const auto paving =
        std::find_if(sets.begin(), sets.end(), [](const Set& s) { return s.name == "0ad_paving_india"; });
    if (paving != sets.end() && read("gk_castell_wall_v01", other, other_c) &&
        other_c == paving->convention) {
        Set s = *paving;
        OIIO::ImageBufAlgo::cut(s.tiles[3], other, ROI(0, s.tw, 0, s.th));
        relief::UdimReport report;
        std::vector<ImageBuf> got;
        if (!relief::height_udim(got, s.udim(), options_for(s, relief::UdimMode::Auto), &report)) {
            std::fprintf(stderr, "bench_udim: replaced tile: %s\n", relief::geterror().c_str());
            return 1;
        }
        const std::vector<float> alone =
            pixels(relief::height(s.tiles[3], options_for(s, relief::UdimMode::Each)));
        const std::vector<float> replaced = pixels(got[3]);
        double diff = 0;
        for (std::size_t i = 0; i < alone.size(); ++i)
            diff = std::max(diff, double(std::abs(alone[i] - replaced[i])));
        const double border = border_ratio(assemble(got, s.tw, s.th), s.tw, s.th, 3);
        std::fprintf(md,
                     "\nTile 1012 of 0ad_paving_india replaced by the top-left %dx%d of gk_castell_wall_v01 "
                     "(udim=auto):\n\n| edge | slope correlation across the edge / between neighbours | "
                     "joined |\n|---|---|---|\n",
                     s.tw, s.th);
        for (const relief::UdimEdge& e : report.edges)
            std::fprintf(md, "| %d-%d | %.3f / %.3f | %s |\n", e.a, e.b, e.seam, e.adjacent,
                         e.joined ? "yes" : "no");
        std::fprintf(
            md,
            "\nThe replaced tile against its own single run: max |difference| %.3g texels. Border ratio "
            "of the three remaining tiles: %.3f.\n",
            diff, border);
        std::printf("replaced 1012: max diff to its single run %.3g, border ratio of the others %.3f\n", diff,
                    border);
    }
    if (picture.size() == 2) {
        write_picture(out / "udim_before_after.png", picture, picture_w, picture_h, 512);
        std::fprintf(md,
                     "\n![nx_brickfloor as four tiles: each (left), auto (right)](udim_before_after.png)\n\n"
                     "nx_brickfloor's heights as four UDIM tiles, each panel scaled to its own range: "
                     "udim=each (left), every tile with its own zero mean and low frequencies, and udim=auto "
                     "(right), the set as one surface.\n");
    }
    std::fclose(md);
    return 0;
}
