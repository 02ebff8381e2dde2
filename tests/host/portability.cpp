// SPDX-License-Identifier: Apache-2.0
// The "portability" label: every stage, run by relief itself on Oclgrind,
// an OpenCL device simulator that checks what a CPU device cannot show:
// data races between work-items, barriers, local-memory bounds, API misuse
// and uninitialised values. Two runs per stage, as a user would make them:
//   races:  oclgrind --data-races --check-api --local-mem-size 32768
//           --max-wgsize 256 (kernels built as a driver builds them), and
//           again with a 64-item, 16 KiB device (launch shapes from queries);
//   uninitialized: oclgrind --uninitialized --build-options -cl-opt-disable
//           (Oclgrind 21.10's uninitialised-value plugin stops at LLVM's
//           `freeze`, which only optimised code has).
// Each run must exit 0, print nothing but relief's own lines (Oclgrind
// prints its reports on stderr), and equal the test device's result: 1e-3
// of the result's standard deviation, 2% for the correction's offsets and
// the bake (line searches may branch apart within their precision).
// Maps are about 64 x 64 texels: seconds each on the simulator.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "support/images.h"
#include "support/run_cli.h"

namespace fs = std::filesystem;
using relief::test::file_pixels;
using relief::test::run_cli;

namespace {

struct Simulator {
    const char* name;
    const char* options;
};

const Simulator kRaces{"races", "--data-races --check-api --local-mem-size 32768 --max-wgsize 256"};
const Simulator kSmallDevice{"small device",
                             "--data-races --check-api --local-mem-size 16384 --max-wgsize 64"};
const Simulator kUninitialized{"uninitialized", "--uninitialized --build-options -cl-opt-disable"};

bool have_oclgrind()
{
    return std::system("command -v oclgrind >/dev/null 2>&1") == 0;
}

// Lines of stderr that are not relief's own: Oclgrind's reports (each
// starts a block of indented lines), its "errors generated" summary, a
// crash's message.
std::vector<std::string> foreign_lines(const std::string& err)
{
    std::vector<std::string> out;
    std::istringstream in(err);
    for (std::string line; std::getline(in, line);)
        if (!line.empty() && line.rfind("relief: ", 0) != 0)
            out.push_back(line);
    return out;
}

double standard_deviation(const std::vector<float>& v)
{
    double s = 0.0, s2 = 0.0;
    for (float x : v) {
        s += x;
        s2 += double(x) * x;
    }
    const double n = double(std::max<std::size_t>(v.size(), 1));
    return std::sqrt(std::max(0.0, s2 / n - (s / n) * (s / n)));
}

// The inputs every case shares, made once per process on the test device
// from the bundled metal sample: a 64 x 64 and a 64 x 48 crop, a mask, a
// 32 x 32 height in texels and a colour texture of its size.
struct Inputs {
    fs::path dir, n64, n6448, n64_alpha, mask, h32, colour32, h64;
    // Thin maps for VkFFT under a GPU's limits: 8192 and 16384 points take
    // more than one pass in 32 KiB of local memory, 4099 is prime.
    fs::path x8192, y16384, x4099;
};

const Inputs& inputs()
{
    static const Inputs in = [] {
        Inputs i;
        // Per process: ctest runs the three cases side by side.
        i.dir = relief::test::scratch("portability-" + std::to_string(::getpid()));
        const std::string sample = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
        const std::string height = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/height.png";
        auto cut = [&](const std::string& from, int w, int h, int x, int y, const fs::path& to,
                       int channels) {
            auto src = OIIO::ImageInput::open(from);
            REQUIRE(src);
            OIIO::ImageSpec spec = src->spec();
            std::vector<float> all(std::size_t(spec.width) * spec.height * spec.nchannels);
            REQUIRE(src->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, all.data()));
            std::vector<float> part(std::size_t(w) * h * channels);
            for (int r = 0; r < h; ++r)
                for (int c = 0; c < w; ++c)
                    for (int k = 0; k < channels; ++k)
                        part[(std::size_t(r) * w + c) * channels + k] =
                            all[(std::size_t(r + y) * spec.width + c + x) * spec.nchannels +
                                std::min(k, spec.nchannels - 1)];
            OIIO::ImageBuf b = relief::test::image(w, h, channels, part, OIIO::TypeDesc::UINT8);
            REQUIRE(b.write(to.string()));
        };
        i.n64 = i.dir / "n64.png";
        i.n6448 = i.dir / "n6448.png";
        i.mask = i.dir / "mask64.png";
        i.colour32 = i.dir / "colour32.png";
        cut(sample, 64, 64, 100, 100, i.n64, 3);
        cut(sample, 64, 48, 200, 40, i.n6448, 3);
        cut(height, 64, 64, 100, 100, i.mask, 1);
        cut(sample, 32, 32, 300, 300, i.colour32, 3);
        auto thin = [&](int w, int h, const fs::path& to) {
            std::vector<float> px(std::size_t(w) * h * 3);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    const double gx = 0.2 * std::sin(2.0 * M_PI * 5.0 * x / w + y),
                                 gy = 0.2 * std::cos(2.0 * M_PI * 3.0 * y / h + x);
                    const double len = std::sqrt(gx * gx + gy * gy + 1.0);
                    float* t = &px[(std::size_t(y) * w + x) * 3];
                    t[0] = float(0.5 - 0.5 * gx / len);
                    t[1] = float(0.5 + 0.5 * gy / len);
                    t[2] = float(0.5 + 0.5 / len);
                }
            REQUIRE(relief::test::image(w, h, 3, px, OIIO::TypeDesc::UINT16).write(to.string()));
        };
        i.x8192 = i.dir / "x8192.png";
        i.y16384 = i.dir / "y16384.png";
        i.x4099 = i.dir / "x4099.png";
        thin(8192, 2, i.x8192);
        thin(2, 16384, i.y16384);
        thin(4099, 2, i.x4099);
        i.h32 = i.dir / "h32.exr";
        i.h64 = i.dir / "h64.exr";
        const fs::path n32 = i.dir / "n32.png";
        cut(sample, 32, 32, 300, 300, n32, 3);
        REQUIRE(run_cli("'" + n32.string() + "' --height -o '" + i.h32.string() + "'").rc == 0);
        REQUIRE(run_cli("'" + i.n64.string() + "' --height:boundary=free -o '" + i.h64.string() + "'").rc ==
                0);
        return i;
    }();
    return in;
}

// Runs `args` (relief's arguments, with OUT where the output goes) on the
// test device and under `sim`, and compares.
void check_stage(const std::string& name, const std::string& args, const Simulator& sim,
                 double tolerance_of_std, double tolerance_of_max)
{
    const Inputs& in = inputs();
    const std::string tag = name + "." + std::string(sim.name).substr(0, 5);
    auto with_output = [&](const fs::path& out) {
        std::string a = args;
        a.replace(a.find("OUT"), 3, "'" + out.string() + "'");
        return a;
    };
    const fs::path ref = in.dir / (tag + ".reference.exr"), got = in.dir / (tag + ".oclgrind.exr");
    const auto r = run_cli(with_output(ref));
    INFO(name << " on the test device: " << r.err);
    REQUIRE(r.rc == 0);
    // The simulator's own binaries, per configuration (its build options are
    // not part of the cache key); RELIEF_DEVICE emptied: under oclgrind the
    // simulator is the only device.
    const fs::path cache = in.dir / (std::string("cache-") + sim.name);
    const auto s = run_cli(with_output(got), "RELIEF_DEVICE= RELIEF_CACHE_DIR='" + cache.string() +
                                                 "' oclgrind " + sim.options);
    const std::vector<std::string> reports = foreign_lines(s.err);
    INFO(name << " under oclgrind " << sim.options << " (exit " << s.rc << "):\n" << s.err.substr(0, 4000));
    REQUIRE(s.rc == 0);
    CHECK(reports.empty());
    const std::vector<float> a = file_pixels(ref), b = file_pixels(got);
    REQUIRE(!a.empty());
    REQUIRE(a.size() == b.size());
    const double diff = relief::test::max_abs_diff(a, b);
    const double bound =
        std::max(tolerance_of_std * standard_deviation(a), tolerance_of_max * relief::test::max_abs(a));
    INFO("max |oclgrind - device| " << diff << ", allowed " << bound);
    CHECK(diff <= bound);
}

// The stages whose names start with one of these: the height's, the
// correction's line searches, its other moves and the bake.
const std::vector<std::string> kHeightStages = {"slopes", "poisson", "rays"};
const std::vector<std::string> kSearchStages = {"correct brent", "correct golden", "correct ternary"};
const std::vector<std::string> kMoveStages = {"correct hats", "correct global", "bake"};

// Every stage of the races and the uninitialised-value runs; `sims` picks.
// With `prefixes`, only the stages whose names start with one of them, or
// with `others`, only those that do not.
void every_stage(const std::vector<Simulator>& sims, const std::vector<std::string>& prefixes = {},
                 bool others = false)
{
    if (!have_oclgrind()) {
        relief::test::mark_skipped("oclgrind is not installed (scripts/setup installs it)");
        return;
    }
    const Inputs& in = inputs();
    const std::string n64 = "'" + in.n64.string() + "'", n6448 = "'" + in.n6448.string() + "'";
    const std::string h32 = "'" + in.h32.string() + "'", h64 = "'" + in.h64.string() + "'";
    struct Stage {
        std::string name, args;
        double of_std, of_max;
        // The thin maps' transforms (Bluestein above all) take minutes each
        // unoptimised on the simulator: races and the small device only.
        bool optimised_only = false;
    };
    const std::vector<Stage> stages = {
        {"slopes", n64 + " --slopes -o OUT", 1e-3, 0},  // DDM and the curl sums (normal=auto)
        {"poisson periodic", n64 + " --height:boundary=periodic -o OUT", 1e-3, 0},
        {"poisson free", n6448 + " --height:boundary=free -o OUT", 1e-3, 0},
        {"poisson masked", n64 + " --height:mask='" + in.mask.string() + "' -o OUT", 1e-3, 0},
        {"poisson highpass", n64 + " --height:boundary=periodic:highpass=16 -o OUT", 1e-3, 0},
        // one axis periodic, the other free: the DCT along axis 1, transposed for y
        {"poisson periodic,free", n6448 + " --height:boundary=periodic,free -o OUT", 1e-3, 0},
        {"poisson free,periodic masked",
         n64 + " --height:boundary=free,periodic:mask='" + in.mask.string() + "' -o OUT", 1e-3, 0},
        {"poisson 8192 free", "'" + in.x8192.string() + "' --height:boundary=free:normal=opengl -o OUT", 1e-3,
         0, true},
        {"poisson 16384 periodic",
         "'" + in.y16384.string() + "' --height:boundary=periodic:normal=opengl -o OUT", 1e-3, 0, true},
        {"poisson 4099 periodic",
         "'" + in.x4099.string() + "' --height:boundary=periodic:normal=opengl -o OUT", 1e-3, 0, true},
        {"rays reference", n64 + " --height:method=rays:impl=reference:rays=8:radius=8 -o OUT", 1e-3, 0},
        {"rays periodic", n64 + " --height:method=rays:rays=8:radius=8:boundary=periodic -o OUT", 1e-3, 0},
        // clip: the FFT inside, chains in the band; radius 40 leaves no inside
        {"rays clip", n6448 + " --height:method=rays:rays=8:radius=8:boundary=clip -o OUT", 1e-3, 0},
        {"rays clip chains", n6448 + " --height:method=rays:rays=8:radius=40:boundary=clip -o OUT", 1e-3, 0},
        // Two iterations: every kernel of a line search runs in each (on
        // the simulator unoptimised, each iteration took 5 s of 28).
        {"correct brent", h32 + " --correct:iterations=2:levels=1 -o OUT", 0, 0.02},
        {"correct golden", h32 + " --correct:iterations=2:levels=1:search=golden -o OUT", 0, 0.02},
        {"correct ternary", h32 + " --correct:iterations=2:levels=1:search=ternary -o OUT", 0, 0.02},
        // hat moves: one work-item per hat, radius 2 to 8 (a sweep each iteration)
        {"correct hats", h32 + " --correct:iterations=2:levels=1:hats=always -o OUT", 0, 0.02},
        // global steps: the gradient, the lattices down and up, the limits' min/max sums
        {"correct global", h32 + " --correct:iterations=2:levels=1:hats=off:global=always -o OUT", 0, 0.02},
        {"bake",
         "'" + in.colour32.string() + "' " + h32 + " --correct:iterations=2:levels=1 --bake -d float -o OUT",
         0, 0.02},
        {"normals", h64 + " --normals -o OUT", 1e-3, 0},
        {"preview", n64 + " " + h64 + " --preview -d float -o OUT", 0, 0.02},
        {"tessellation", h64 + " --tessellation:patch=16:error=0.5 -o OUT", 1e-3, 0},
        {"mesh", h64 + " --mesh:patch=16:error=0.5:out='" + (in.dir / "mesh.obj").string() + "' -o OUT", 1e-3,
         0},
    };
    for (const Simulator& sim : sims)
        for (const Stage& st : stages) {
            const bool listed = std::any_of(prefixes.begin(), prefixes.end(),
                                            [&](const std::string& p) { return st.name.rfind(p, 0) == 0; });
            if (!prefixes.empty() && listed == others)
                continue;
            if (st.optimised_only && std::string(sim.name) == kUninitialized.name)
                continue;
            SECTION(st.name + ", " + sim.name)
            {
                check_stage(st.name, st.args, sim, st.of_std, st.of_max);
            }
        }
}

}  // namespace

TEST_CASE("portability: every stage on Oclgrind, races and API checks, as a driver builds it",
          "[portability]")
{
    every_stage({kRaces});
}

TEST_CASE("portability: every stage on Oclgrind with 64-item groups and 16 KiB of local memory",
          "[portability]")
{
    every_stage({kSmallDevice});
}

// In four parts, which ctest runs side by side: unoptimised on the
// simulator, the stages together took five minutes, the longest entry of
// the label by far (the correction's six, 3.8 of those minutes).
TEST_CASE("portability: the height stages on Oclgrind, uninitialised values, unoptimised", "[portability]")
{
    every_stage({kUninitialized}, kHeightStages);
}

TEST_CASE("portability: the correction's line searches on Oclgrind, uninitialised values, unoptimised",
          "[portability]")
{
    every_stage({kUninitialized}, kSearchStages);
}

TEST_CASE("portability: the correction's hats and global steps and the bake on Oclgrind, uninitialised "
          "values, unoptimised",
          "[portability]")
{
    every_stage({kUninitialized}, kMoveStages);
}

TEST_CASE("portability: the other stages on Oclgrind, uninitialised values, unoptimised", "[portability]")
{
    std::vector<std::string> listed = kHeightStages;
    listed.insert(listed.end(), kSearchStages.begin(), kSearchStages.end());
    listed.insert(listed.end(), kMoveStages.begin(), kMoveStages.end());
    every_stage({kUninitialized}, listed, true);
}
