// SPDX-License-Identifier: Apache-2.0
// Hardening (the [stress] tests ctest labels "stress"): damaged files
// through the command line, a size sweep of every boundary through the
// API, and a 16384^2 map in bounded memory against its own tile.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <nlohmann/json.hpp>
#include <vector>

#include "relief/relief.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/large_maps.h"
#include "support/run_cli.h"

namespace fs = std::filesystem;
using namespace relief;

namespace {

// The 128 damaged files: 8 small maps in the formats relief reads (8 and
// 16 bit PNG, RGBA PNG, half and float EXR, 8-bit and float TIFF, TGA),
// each damaged 16 ways (truncated, header or body bytes flipped or set,
// blocks zeroed, halves repeated, garbage appended, the magic alone).
std::vector<fs::path> damaged_files(const fs::path& dir)
{
    const int n = 40;
    const std::vector<std::uint8_t> tile = test::tiling_normal_tile(n, 11);
    std::vector<float> px(tile.begin(), tile.end());
    for (float& v : px)
        v /= 255.0f;
    std::vector<float> rgba;
    for (std::size_t i = 0; i < px.size(); i += 3)
        rgba.insert(rgba.end(), {px[i], px[i + 1], px[i + 2], float(i % 7) / 6.0f});
    std::vector<float> signed_px(px);
    for (float& v : signed_px)
        v = 2.0f * v - 1.0f;
    struct Source {
        const char* name;
        int channels;
        const std::vector<float>* pixels;
        OIIO::TypeDesc type;
    };
    const Source sources[] = {{"n8.png", 3, &px, OIIO::TypeDesc::UINT8},
                              {"n16.png", 3, &px, OIIO::TypeDesc::UINT16},
                              {"rgba.png", 4, &rgba, OIIO::TypeDesc::UINT8},
                              {"half.exr", 3, &signed_px, OIIO::TypeDesc::HALF},
                              {"float.exr", 3, &signed_px, OIIO::TypeDesc::FLOAT},
                              {"n8.tif", 3, &px, OIIO::TypeDesc::UINT8},
                              {"float.tif", 3, &signed_px, OIIO::TypeDesc::FLOAT},
                              {"n8.tga", 3, &px, OIIO::TypeDesc::UINT8}};
    std::vector<fs::path> files;
    for (const Source& s : sources) {
        const fs::path clean = dir / (std::string("clean-") + s.name);
        REQUIRE(test::image(n, n, s.channels, *s.pixels, s.type).write(clean.string()));
        const std::string bytes = test::slurp(clean);
        fs::remove(clean);
        REQUIRE(bytes.size() > 128);
        for (int k = 0; k < 16; ++k) {
            std::mt19937 rng(unsigned(1000 * k + bytes.size()));
            auto at = [&](std::size_t from, std::size_t to) { return from + rng() % (to - from); };
            std::string d = bytes;
            const std::size_t size = d.size(), head = std::min<std::size_t>(64, size);
            switch (k) {
            case 0:
            case 1:
            case 2:
            case 3:
            case 4: {
                const double keep[] = {0.125, 0.25, 0.5, 0.75, 0.95};
                d.resize(std::size_t(size * keep[k]));
                break;
            }
            case 5:
            case 6:
            case 7:
            case 8:
                for (int i = 0; i < (1 << (k - 5)); ++i)
                    d[at(0, head)] ^= char(1 + rng() % 255);
                break;
            case 9:
                for (int i = 0; i < 16; ++i)
                    d[at(head, size)] ^= char(1 + rng() % 255);
                break;
            case 10: {
                const std::size_t from = at(head, size - 64);
                std::fill_n(d.begin() + from, 64, '\0');
                break;
            }
            case 11:
                for (std::size_t i = size / 2; i < size; ++i)
                    d[i] = char(rng());
                break;
            case 12: {
                const std::size_t from = at(8, head - 4);
                std::fill_n(d.begin() + from, 4, '\xff');
                break;
            }
            case 13: d = bytes.substr(0, size / 2) + bytes.substr(0, size / 2); break;
            case 14:
                for (int i = 0; i < 1024; ++i)
                    d.push_back(char(rng()));
                break;
            case 15: d.resize(8); break;
            }
            const std::string name = std::string("damaged-") + std::to_string(k) + "-" + s.name;
            std::ofstream(dir / name, std::ios::binary) << d;
            files.push_back(dir / name);
        }
    }
    REQUIRE(files.size() == 128);
    return files;
}

// A damaged file's result: a finite output, or a refusal that says why and
// leaves no output.
void check_outcome(const fs::path& out, bool refused, const std::string& message, int& ok, int& refusals)
{
    if (refused) {
        ++refusals;
        CHECK_FALSE(message.empty());
        CHECK_FALSE(fs::exists(out));
    } else {
        ++ok;
        const std::vector<float> v = test::file_pixels(out);
        REQUIRE_FALSE(v.empty());
        CHECK(std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); }));
        fs::remove(out);
    }
}

// Every damaged file through `command`, as a farm runs them: all 128 as
// the jobs of one --batch (one process: a decoder that corrupts its
// state fails the jobs after it), each job ok with a finite result or
// failed with its message and no output, the batch exiting 1. Then one
// file of each kind of damage, in turn of format, as a single run: exit 0
// with a finite result, or exit 1 with "relief: error:" and no output.
// Never a crash, a sanitizer's exit code, a hang or a file left behind.
// (128 single runs took 3 to 4 minutes a command under the sanitizers,
// most of it starting processes.)
void run_damaged(const std::string& command, const std::string& tag)
{
    const fs::path dir = test::scratch("hardening/damaged-" + tag);
    const std::vector<fs::path> files = damaged_files(dir);
    auto out_of = [&](const fs::path& in) { return dir / ("out-" + in.filename().string() + ".exr"); };
    const fs::path jobs = dir / "jobs.txt", log = dir / "jobs.jsonl";
    {
        std::ofstream j(jobs);
        for (const fs::path& in : files)
            j << "'" << in.string() << "' " << command << " -o '" << out_of(in).string() << "'\n";
    }
    const auto b =
        test::run_cli("--batch '" + jobs.string() + "' --log '" + log.string() + "'", "timeout 600");
    INFO("batch: exit " << b.rc << "\n" << b.err);
    REQUIRE(b.rc == 1);
    std::vector<nlohmann::json> records(files.size());  // by job number (from 0)
    std::ifstream lines(log);
    std::size_t logged = 0;
    for (std::string line; std::getline(lines, line); ++logged) {
        const nlohmann::json r = nlohmann::json::parse(line);
        REQUIRE(r.at("job").get<std::size_t>() < files.size());
        records[r.at("job").get<std::size_t>()] = r;
    }
    REQUIRE(logged == files.size());
    int ok = 0, refused = 0;
    for (std::size_t k = 0; k < files.size(); ++k) {
        const nlohmann::json& r = records[k];
        INFO(files[k].filename().string() << ": " << r.dump());
        REQUIRE(r.is_object());  // one record per job
        const std::string status = r.at("status");
        REQUIRE((status == "ok" || status == "failed"));
        check_outcome(out_of(files[k]), status == "failed", r.value("message", ""), ok, refused);
        if (status == "failed")
            CHECK(b.err.find("relief: job " + std::to_string(k) + " (") != std::string::npos);
    }
    std::printf("damaged files, %s: %d ran, %d refused\n", command.c_str(), ok, refused);
    CHECK(refused > 0);
    CHECK(ok > 0);  // some damage leaves a readable map (a flipped pixel, garbage after the end)
    int single_ok = 0, single_refused = 0;
    for (int kind = 0; kind < 16; ++kind) {
        const fs::path& in = files[std::size_t((kind % 8) * 16 + kind)];
        const auto r = test::run_cli("'" + in.string() + "' " + command + " -o '" + out_of(in).string() + "'",
                                     "timeout 120");
        INFO(in.filename().string() << ": exit " << r.rc << "\n" << r.err);
        REQUIRE((r.rc == 0 || r.rc == 1));
        check_outcome(out_of(in), r.rc == 1,
                      r.rc == 1 && r.err.find("relief: error: ") != std::string::npos ? r.err : "", single_ok,
                      single_refused);
    }
    CHECK(single_refused > 0);
    fs::remove(jobs);
    fs::remove(log);
    for (const auto& e : fs::directory_iterator(dir))
        CHECK(e.path().filename().string().rfind("damaged-", 0) == 0);  // nothing else left behind
}

}  // namespace

TEST_CASE("hardening: 128 damaged files through --height exit 0 or 1, say why, leave nothing",
          "[stress][damaged]")
{
    run_damaged("--height", "poisson");
}

TEST_CASE("hardening: 128 damaged files through --height:method=rays:radius=16", "[stress][damaged]")
{
    run_damaged("--height:method=rays:radius=16", "rays");
}

TEST_CASE("hardening: 128 damaged files through --correct:scale=0.05", "[stress][damaged]")
{
    run_damaged("--correct:scale=0.05", "correct");
}

// The integrators take the slopes over and make the result last unless a
// report needs the slopes after: both ways must give the same bits, at
// every kind of size (1 x 1, single rows and columns, primes, odd, even).
TEST_CASE("hardening: size sweep, every boundary: taking the slopes over changes no bit", "[stress][sizes]")
{
    const int sizes[][2] = {{1, 1},   {1, 9},   {9, 1},     {2, 2},   {3, 5},
                            {17, 31}, {64, 64}, {127, 129}, {257, 3}, {1000, 999}};
    for (const auto& wh : sizes) {
        const int w = wh[0], h = wh[1];
        std::vector<float> px(std::size_t(w) * h * 3);
        std::mt19937 rng(unsigned(w * 131 + h));
        std::normal_distribution<float> slope(0.0f, 0.3f);
        for (std::size_t i = 0; i < px.size(); i += 3) {
            const float gx = slope(rng), gy = slope(rng), len = std::sqrt(gx * gx + gy * gy + 1.0f);
            px[i] = -gx / len;
            px[i + 1] = -gy / len;
            px[i + 2] = 1.0f / len;
        }
        const OIIO::ImageBuf normals = test::image(w, h, 3, px);
        for (HeightMethod m : {HeightMethod::Poisson, HeightMethod::Rays})
            for (Boundary b : {Boundary::Periodic, Boundary::Free}) {
                INFO(w << "x" << h << (m == HeightMethod::Rays ? " rays " : " poisson ")
                       << (b == Boundary::Periodic ? "periodic" : "free"));
                HeightOptions o;
                o.method = m;
                o.boundary = b;
                o.normals.convention = NormalConvention::OpenGL;
                o.rays = 8;
                o.radius = 12;
                const OIIO::ImageBuf taken = relief::height(normals, o);
                REQUIRE_FALSE(taken.has_error());
                HeightReport report;
                o.report = &report;
                const OIIO::ImageBuf kept = relief::height(normals, o);
                REQUIRE_FALSE(kept.has_error());
                REQUIRE(taken.spec().width == w);
                REQUIRE(taken.spec().height == h);
                const std::vector<float> a = test::pixels(taken), c = test::pixels(kept);
                CHECK(std::memcmp(a.data(), c.data(), sizeof(float) * a.size()) == 0);
                double mean = 0;
                for (float v : a) {
                    REQUIRE(std::isfinite(v));
                    mean += v;
                }
                CHECK(std::abs(mean / a.size()) < 1e-3);
                CHECK(report.width == w);
            }
    }
}

#ifndef RELIEF_SANITIZE
#define RELIEF_SANITIZE 0
#endif

// The bound: 24 bytes a texel at the peak, the process's own
// (OpenCL, PoCL's compiler, the libraries) included; and periodic results
// of a map made of 8 x 8 copies of a tile equal the tile's own.
TEST_CASE(
    "hardening: a 16384^2 tiling map peaks under 24 bytes a texel and its tile equals the 2048^2 result",
    "[stress][huge]")
{
    const fs::path dir = test::scratch("hardening/huge");
    const int tile = 2048, repeats = 8, n = tile * repeats;
    const std::vector<std::uint8_t> tile_px = test::tiling_normal_tile(tile);
    const std::string big = (dir / "big.tif").string(), small = (dir / "tile.tif").string();
    REQUIRE(test::write_tiled_map(small, tile_px, tile, 1));
    REQUIRE(test::write_tiled_map(big, tile_px, tile, repeats));
    for (const std::string command : {"--height", "--height:method=rays:radius=16"}) {
        INFO(command);
        const std::string out_big = (dir / "big.exr").string(), out_small = (dir / "tile.exr").string();
        double peak = 0, peak_small = 0;
        const std::string cli = "'" + std::string(RELIEF_CLI) + "' ";
        REQUIRE(test::run_measured(cli + "'" + small + "' " + command + " -o '" + out_small + "'",
                                   peak_small) == 0);
        REQUIRE(test::run_measured(cli + "'" + big + "' " + command + " -o '" + out_big + "'", peak) == 0);
        const double per_texel = peak / (double(n) * n);
        std::printf("%s on %dx%d: peak RSS %.2f GB, %.2f bytes per texel\n", command.c_str(), n, n,
                    peak / 1e9, per_texel);
        if (!RELIEF_SANITIZE)  // the sanitizers' shadow memory and quarantine are theirs
            CHECK(per_texel <= 24.0);

        // The big result's first tile against the tile's result.
        auto in = OIIO::ImageInput::open(out_big);
        REQUIRE(in);
        REQUIRE(in->spec().width == n);
        std::vector<float> rows(std::size_t(n) * tile), got(std::size_t(tile) * tile);
        REQUIRE(in->read_scanlines(0, 0, 0, tile, 0, 0, 1, OIIO::TypeDesc::FLOAT, rows.data()));
        in->close();
        for (int y = 0; y < tile; ++y)
            std::copy_n(&rows[std::size_t(y) * n], tile, &got[std::size_t(y) * tile]);
        rows = std::vector<float>();
        const std::vector<float> want = test::file_pixels(out_small);
        REQUIRE(want.size() == got.size());
        const double sd = test::rms(want), worst = test::max_abs_diff(want, got);
        std::printf("%s: tile of the %d^2 result against the %d^2 result: max |diff| %.3g = %.3g of std\n",
                    command.c_str(), n, tile, worst, worst / sd);
        CHECK(sd > 1.0);
        CHECK(worst <= 1e-4 * sd);
        fs::remove(out_big);
    }
    fs::remove(big);
}

// VkFFT's Bluestein kernels crash PoCL past about 21000 points (a damaged
// TIFF header made a 40 x 65320 map): such lengths are refused with what to
// do before the integration starts, and clip rays walk every ray instead.
TEST_CASE("hardening: an axis too long for Bluestein's FFT is refused, clip rays walk instead",
          "[cli][errors][slow][kernel]")
{
    const fs::path dir = test::scratch("hardening/bluestein");
    const int w = 40, h = 25013;  // prime; wide enough for clip's FFT interior at radius 8
    std::vector<float> px(std::size_t(w) * h * 3);
    for (std::size_t i = 0; i < px.size(); i += 3) {
        px[i] = 0.5f + 0.1f * float(std::sin(0.01 * double(i)));
        px[i + 1] = 0.5f;
        px[i + 2] = 1.0f;
    }
    const std::string in = (dir / "long.png").string(), out = (dir / "h.exr").string();
    REQUIRE(test::image(w, h, 3, px, OIIO::TypeDesc::UINT8).write(in));
    for (const char* command :
         {"--height:boundary=periodic", "--height:boundary=free", "--height:method=rays:boundary=periodic"}) {
        INFO(command);
        const auto r = test::run_cli("'" + in + "' " + command + " -o '" + out + "'");
        CHECK(r.rc == 1);
        CHECK(r.err.find("relief: error: height: ") != std::string::npos);
        CHECK(r.err.find(
                  "an FFT along an axis of 25013 texels, which has a prime factor above 13, is "
                  "supported only up to 20000 texels; crop the map to 25000 or pad it to 25025 texels") !=
              std::string::npos);
        CHECK_FALSE(fs::exists(out));
    }
    const auto r = test::run_cli(
        "'" + in + "' --height:method=rays:radius=8:boundary=clip:normal=opengl -o '" + out + "'");
    CHECK(r.rc == 0);
    const std::vector<float> v = test::file_pixels(out);
    REQUIRE(v.size() == std::size_t(w) * h);
    CHECK(std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); }));
}
