// SPDX-License-Identifier: Apache-2.0
// Any OpenCL device: how `auto` ranks devices, RELIEF_DEVICE, the float
// paths (RELIEF_FP64), launch shapes from device limits, the loop limit of
// devices that cut work-items short, and three OpenCL implementations
// registered at once.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "check/check_stage.h"
#include "device/compute_context.h"
#include "errors.h"
#include "device/opencl_context.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/run_cli.h"
#include "support/scoped_env.h"

namespace fs = std::filesystem;
using namespace relief::host;
using relief::test::run_cli;

namespace {

DeviceInfo device(const char* platform, const char* name, bool gpu, bool cpu, bool fp64,
                  unsigned long long memory, int p)
{
    DeviceInfo d;
    d.platform_index = p;
    d.device_index = 0;
    d.platform = platform;
    d.name = name;
    d.is_gpu = gpu;
    d.is_cpu = cpu;
    d.simulator = std::string(platform).find("Oclgrind") != std::string::npos;
    d.has_fp64 = fp64;
    d.global_memory = memory;
    return d;
}

using relief::test::ScopedEnv;

// Runs relief's `args` with OUT replaced by `out` (and `env` in front);
// the result's pixels.
std::vector<float> run_to_pixels(const std::string& args, const fs::path& out, const std::string& env = "")
{
    std::string a = args;
    a.replace(a.find("OUT"), 3, "'" + out.string() + "'");
    auto r = run_cli(a, env);
    INFO(env << " relief " << a << "\n" << r.err);
    REQUIRE(r.rc == 0);
    return relief::test::file_pixels(out);
}

}  // namespace

TEST_CASE("devices: auto ranks hardware GPUs, then CPUs, then others, simulators last, by fp64, then memory",
          "[devices]")
{
    const std::vector<DeviceInfo> listed = {
        device("Oclgrind", "Oclgrind Simulator", true, false, true, 1ull << 40, 0),
        device("rusticl", "llvmpipe", false, true, false, 2ull << 30, 1),
        device("Portable Computing Language", "pthread", false, true, true, 4ull << 30, 2),
        device("FPGA SDK", "emulator", false, false, true, 8ull << 30, 3),
        device("Intel", "integrated", true, false, false, 8ull << 30, 4),
        device("NVIDIA CUDA", "discrete", true, false, true, 24ull << 30, 5),
        device("NVIDIA CUDA", "small", true, false, true, 8ull << 30, 6),
    };
    const std::vector<DeviceInfo> r = rank_devices(listed);
    std::vector<int> order;
    for (const DeviceInfo& d : r)
        order.push_back(d.platform_index);
    // GPUs with fp64 by memory, the GPU without; PoCL (fp64) before
    // llvmpipe; the accelerator; the simulator, though it calls itself a GPU.
    CHECK(order == std::vector<int>{5, 6, 4, 2, 1, 3, 0});
    // The same set in another order ranks the same (ties keep list order).
    std::vector<DeviceInfo> reversed(listed.rbegin(), listed.rend());
    std::vector<int> again;
    for (const DeviceInfo& d : rank_devices(reversed))
        again.push_back(d.platform_index);
    CHECK(again == order);
}

TEST_CASE("devices: RELIEF_DEVICE says what auto means, explicit specs are left alone", "[devices]")
{
    const std::vector<DeviceInfo> all = relief::host::list_devices();
    REQUIRE_FALSE(all.empty());
    const DeviceInfo& last = all.back();
    const std::string spec = std::to_string(last.platform_index) + ":" + std::to_string(last.device_index);
    {
        ScopedEnv env("RELIEF_DEVICE", spec.c_str());
        const DeviceInfo d = choose_device("auto");
        CHECK(d.platform_index == last.platform_index);
        CHECK(d.device_index == last.device_index);
        // cpu stays the best-ranked CPU, whatever RELIEF_DEVICE says
        CHECK(choose_device("cpu").is_cpu);
    }
    {
        ScopedEnv env("RELIEF_DEVICE", "42:0");
        // The devices there are, numbered as --list-devices numbers them.
        const DeviceInfo first = relief::host::list_devices().front();
        CHECK_THROWS_WITH(choose_device("auto"),
                          Catch::Contains("no OpenCL device 42:0; the devices here: " + first.describe()) &&
                              Catch::EndsWith(" (RELIEF_DEVICE=42:0)"));
    }
    {
        ScopedEnv env("RELIEF_DEVICE", "banana");
        CHECK_THROWS_WITH(choose_device("auto"),
                          Catch::Contains("bad device 'banana'") && Catch::Contains("(RELIEF_DEVICE)"));
    }
    {
        ScopedEnv env("RELIEF_DEVICE", "");
        const DeviceInfo ranked = rank_devices(all).front();
        CHECK(choose_device("auto").name == ranked.name);
    }
    // The command line: a bad RELIEF_DEVICE is an error naming it.
    const std::string normal = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
    const fs::path d = relief::test::scratch("relief_device");
    auto r = run_cli("'" + normal + "' --slopes -o '" + (d / "s.exr").string() + "'", "RELIEF_DEVICE=42:0");
    CHECK(r.rc == 1);
    CHECK(r.err.find("RELIEF_DEVICE=42:0") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "s.exr"));
}

TEST_CASE("devices: RELIEF_FP64 picks the accumulation path and -v names it", "[devices]")
{
    ComputeContext ctx(choose_device("auto"));
    const bool has = ctx.device().has_fp64;
    {
        ScopedEnv env("RELIEF_FP64", "off");
        CHECK_FALSE(ctx.fp64());
        CHECK(ctx.device().describe().find(has ? "float: RELIEF_FP64=off" : "float: no fp64") !=
              std::string::npos);
    }
    {
        ScopedEnv env("RELIEF_FP64", nullptr);
        CHECK(ctx.fp64() == has);
        CHECK(ctx.device().describe().find(has ? ", fp64)" : "float: no fp64") != std::string::npos);
    }
    {
        ScopedEnv env("RELIEF_FP64", "on");
        if (has)
            CHECK(ctx.fp64());
        else
            CHECK_THROWS_WITH(ctx.fp64(), Catch::Contains("RELIEF_FP64=on") && Catch::Contains("no fp64"));
    }
    {
        ScopedEnv env("RELIEF_FP64", "maybe");
        CHECK_THROWS_WITH(ctx.fp64(), Catch::Contains("RELIEF_FP64 must be auto, on or off, not 'maybe'"));
    }
    const std::string normal = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
    const fs::path d = relief::test::scratch("fp64_cli");
    auto off = run_cli("-v '" + normal + "' --slopes -o '" + (d / "s.exr").string() + "'", "RELIEF_FP64=off");
    CHECK(off.rc == 0);
    CHECK(off.err.find(has ? "float: RELIEF_FP64=off" : "float: no fp64") != std::string::npos);
    auto bad = run_cli("'" + normal + "' --height:method=rays -o '" + (d / "h.exr").string() + "'",
                       "RELIEF_FP64=yes");
    CHECK(bad.rc == 1);
    CHECK(bad.err.find("RELIEF_FP64 must be auto, on or off") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "h.exr"));
}

TEST_CASE("devices: with RELIEF_FP64=off the Poisson, ray and correction results equal the fp64 ones",
          "[devices][slow][kernel]")
{
    // The float paths: Kahan-compensated ray sums, prefix sums re-anchored in
    // blocks, the correction's energies summed in float per work-group (the
    // host adds the groups in double either way). Held to the portability
    // tolerances: 1e-3 of the result's standard deviation, 2% of the
    // largest offset for the correction. Where the device has no fp64 both
    // runs take the float paths and must agree exactly.
    const std::string normal = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
    const std::string dem = std::string(RELIEF_TEST_DATA) + "/dem_jacksboro/normal.png";
    const fs::path d = relief::test::scratch("fp64_off");
    const fs::path own_height = d / "h.exr";
    REQUIRE(run_cli("'" + normal + "' --height -o '" + own_height.string() + "'").rc == 0);
    struct Run {
        std::string name, args;
        bool offsets;
    };
    const std::vector<Run> runs = {
        {"poisson", "'" + dem + "' --height -o OUT", false},
        {"rays periodic", "'" + normal + "' --height:method=rays:boundary=periodic -o OUT", false},
        {"rays clip", "'" + dem + "' --height:method=rays:boundary=clip -o OUT", false},
        {"rays reference", "'" + dem + "' --height:method=rays:impl=reference:rays=16:radius=32 -o OUT",
         false},
        {"correct", "'" + own_height.string() + "' --correct:levels=2:tolerance=1e-4 -o OUT", true},
    };
    for (const Run& r : runs) {
        INFO(r.name);
        const auto pa = run_to_pixels(r.args, d / (r.name + ".fp64.exr"));
        const auto pb = run_to_pixels(r.args, d / (r.name + ".float.exr"), "RELIEF_FP64=off");
        REQUIRE(!pa.empty());
        double bound = 0.0;
        if (r.offsets) {
            bound = 0.02 * relief::test::max_abs(pa);
        } else {
            double s = 0.0, s2 = 0.0;
            for (float v : pa) {
                s += v;
                s2 += double(v) * v;
            }
            const double n = double(pa.size());
            bound = 1e-3 * std::sqrt(std::max(0.0, s2 / n - (s / n) * (s / n)));
        }
        const double diff = relief::test::max_abs_diff(pa, pb);
        INFO("max |float - fp64| " << diff << ", allowed " << bound);
        CHECK(diff <= bound);
    }
}

TEST_CASE("devices: work-groups come from the device's and the kernel's limits", "[devices]")
{
    std::size_t plain = 0;
    {
        ComputeContext ctx(choose_device("auto"));
        auto& c = ctx.impl();
        cl::Kernel k(c.program("ddm.cl"), "flip_row_slope");
        plain = c.group_size(k);
        CHECK(plain >= 1);
        CHECK(plain <= kPreferredGroup);
        CHECK((plain & (plain - 1)) == 0);
        CHECK(plain <= c.max_group);
        // local memory per work-item lowers the group until it fits
        const std::size_t per_item = c.local_memory / 4;
        CHECK(c.group_size(k, per_item) <= 4);
        CHECK_THROWS_AS(c.group_size(k, c.local_memory + 1), Error);
        // a 2-D shape no larger than the device allows, halved evenly
        const cl::NDRange shape = c.group_shape(k, 8, 8);
        CHECK(shape[0] * shape[1] <= c.max_group);
    }
    {
        ScopedEnv g("RELIEF_MAX_WORK_GROUP_SIZE", "64");
        ScopedEnv l("RELIEF_LOCAL_MEM_SIZE", "16K");
        ComputeContext ctx(choose_device("auto"));
        auto& c = ctx.impl();
        CHECK(c.max_group <= 64);
        CHECK(c.local_memory <= 16384);
        cl::Kernel k(c.program("ddm.cl"), "flip_row_slope");
        CHECK(c.group_size(k) <= 64);
        CHECK(c.group_size(k, 1024) <= 16);
        // the longer side halves until the device and the kernel allow it
        const std::size_t limit =
            std::min<std::size_t>(64, k.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(c.device));
        const cl::NDRange shape = c.group_shape(k, 4, 32);
        CHECK(shape[0] * shape[1] <= limit);
        CHECK(2 * shape[0] * shape[1] > limit);
        CHECK(shape[0] <= 4);
        CHECK(shape[1] <= 32);
    }
    for (const std::string bad : {"lots", "-1", "0"}) {
        ScopedEnv g("RELIEF_MAX_WORK_GROUP_SIZE", bad.c_str());
        CHECK_THROWS_WITH(
            ComputeContext(choose_device("auto")),
            Catch::Contains("RELIEF_MAX_WORK_GROUP_SIZE must be a whole number > 0, not '" + bad + "'"));
    }
}

TEST_CASE("devices: results under 64-item groups and 16 KiB equal the device's own launch shapes",
          "[devices][slow][kernel]")
{
    // Every stage whose sums or tiles follow the group size: the masked
    // solve's dot products, the correction's energy sums and phases, the
    // FFTs (VkFFT reads the same limits), the DDM.
    const std::string normal = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
    const std::string height = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/height.png";
    const fs::path d = relief::test::scratch("launch_limits");
    const std::string small = "RELIEF_MAX_WORK_GROUP_SIZE=64 RELIEF_LOCAL_MEM_SIZE=16384";
    // A 4099-texel-wide map: VkFFT plans no real-to-complex transform of
    // that odd length in 16 KiB of local memory, so the rows go through a
    // complex transform there (FftPlan's complex_rows).
    const fs::path wide = d / "wide.exr";
    {
        const int w = 4099, h = 3;
        std::vector<float> px(std::size_t(w) * h * 3);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const double gx = 0.3 * std::sin(2.0 * M_PI * 3.0 * x / w), gy = 0.1 * std::cos(1.7 * y);
                const double len = std::sqrt(gx * gx + gy * gy + 1.0);
                float* t = &px[(std::size_t(y) * w + x) * 3];
                t[0] = float(-gx / len);
                t[1] = float(gy / len);
                t[2] = float(1.0 / len);
            }
        REQUIRE(relief::test::image(w, h, 3, px).write(wide.string()));
    }
    struct Run {
        std::string name, args;
        double tolerance;  // of the result's largest magnitude
    };
    const std::vector<Run> runs = {
        {"masked poisson", "'" + normal + "' --height:mask='" + height + "' -o OUT", 1e-4},
        {"free poisson", "'" + normal + "' --height:boundary=free -o OUT", 1e-5},
        {"clip rays", "'" + normal + "' --height:method=rays:rays=8:radius=16:boundary=clip -o OUT", 1e-5},
        {"correct", "'" + height + "' --correct:scale=0.05:iterations=3:levels=2 -o OUT", 0.02},
        {"periodic 4099 wide", "'" + wide.string() + "' --height:boundary=periodic:normal=opengl -o OUT",
         1e-4},
        {"free 4099 wide", "'" + wide.string() + "' --height:boundary=free:normal=opengl -o OUT", 1e-4},
    };
    for (const Run& r : runs) {
        INFO(r.name);
        const auto pa = run_to_pixels(r.args, d / (r.name + ".a.exr"));
        const auto pb = run_to_pixels(r.args, d / (r.name + ".b.exr"), small);
        CHECK(relief::test::max_abs_diff(pa, pb) <= r.tolerance * relief::test::max_abs(pa));
    }
}

TEST_CASE("devices: a loop limit is found by the probe and respected by the launch shapes",
          "[devices][slow][kernel]")
{
    {
        ComputeContext ctx(choose_device("auto"));
        auto& c = ctx.impl();
        std::lock_guard<std::mutex> lock(c.mutex);
        const std::uint64_t limit = c.loop_limit();
        CHECK(limit > 1000);
        // A limit found is the largest loop that ran to its end: one more
        // iteration (twice, for the probe's resolution) did not.
        if (limit != UINT64_MAX)
            CHECK(limit < (1u << 21));
        CHECK(c.loops_fit(1000));
    }
    // A device that stops loops after 20000 iterations (as RELIEF_LOOP_LIMIT
    // pretends): per-patch tessellation of 32-texel patches would loop about
    // 70000 times per work-item, so it runs per level, with the same levels.
    {
        const std::vector<float> h = relief::test::waves(200, 150, 15.0, 150);
        ComputeContext plain(choose_device("auto"));
        const auto want =
            tessellation_levels(plain, h.data(), 200, 150, 32, 0.3f, 1.0f, TessellationLaunch::PerPatch);
        ScopedEnv env("RELIEF_LOOP_LIMIT", "20000");
        ComputeContext ctx(choose_device("auto"));
        {
            std::lock_guard<std::mutex> lock(ctx.impl().mutex);
            CHECK(ctx.impl().loop_limit() <= 20000);
            CHECK_FALSE(ctx.impl().loops_fit(20001));
        }
        const auto got =
            tessellation_levels(ctx, h.data(), 200, 150, 32, 0.3f, 1.0f, TessellationLaunch::PerPatch);
        CHECK(got == want);
        // 128-texel patches need more than 20000 iterations even per level
        CHECK_THROWS_WITH(tessellation_levels(ctx, h.data(), 200, 150, 128, 0.3f, 1.0f),
                          Catch::Contains("patches of 128 texels need 33024 loop iterations per work-item") &&
                              Catch::Contains("stops loops after") && Catch::Contains("llvmpipe"));
    }
    // The command line says so too, and writes nothing.
    const std::string height = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/height.png";
    const std::string normal = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";
    const fs::path d = relief::test::scratch("loop_limit");
    auto t = run_cli("'" + height + "' --tessellation:patch=128 -o '" + (d / "t.exr").string() + "'",
                     "RELIEF_LOOP_LIMIT=20000");
    CHECK(t.rc == 1);
    CHECK(t.err.find("stops loops after 20000 iterations") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "t.exr"));
    auto r = run_cli("'" + normal + "' --height:method=rays:impl=reference:rays=256:radius=128 -o '" +
                         (d / "r.exr").string() + "'",
                     "RELIEF_LOOP_LIMIT=20000");
    CHECK(r.rc == 1);
    CHECK(r.err.find("impl=reference walks") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "r.exr"));
    // Chains: with the limit (16 lanes of 512-step chains would loop more
    // than 5000 times) they walk one per work-item, the same result.
    const fs::path a = d / "chains.exr", b = d / "chains-limited.exr";
    const std::string clip = "'" + normal + "' --height:method=rays:rays=8:radius=16:boundary=clip:skip=off";
    REQUIRE(run_cli(clip + " -o '" + a.string() + "'").rc == 0);
    auto c = run_cli(clip + " -o '" + b.string() + "'", "RELIEF_LOOP_LIMIT=5000");
    INFO(c.err);
    REQUIRE(c.rc == 0);
    const auto pa = relief::test::file_pixels(a), pb = relief::test::file_pixels(b);
    CHECK(relief::test::max_abs_diff(pa, pb) <= 1e-5 * relief::test::max_abs(pa));
}

TEST_CASE("devices: PoCL, Rusticl and Oclgrind registered at once are all listed and each can be picked",
          "[devices][slow]")
{
    const char* libs[] = {"/usr/lib/x86_64-linux-gnu/libpocl.so.2",
                          "/usr/lib/x86_64-linux-gnu/libRusticlOpenCL.so.1",
                          "/usr/lib/oclgrind/liboclgrind-rt-icd.so"};
    for (const char* lib : libs)
        if (!fs::exists(lib)) {
            relief::test::mark_skipped(std::string(lib) + " is not installed (scripts/setup installs it)");
            return;
        }
    const fs::path d = relief::test::scratch("three_platforms");
    const fs::path vendors = d / "vendors";
    fs::create_directories(vendors);
    std::ofstream(vendors / "pocl.icd") << libs[0] << "\n";
    std::ofstream(vendors / "rusticl.icd") << libs[1] << "\n";
    std::ofstream(vendors / "oclgrind.icd") << libs[2] << "\n";
    const std::string env =
        "OCL_ICD_VENDORS='" + vendors.string() + "' RUSTICL_ENABLE=llvmpipe RELIEF_DEVICE=";
    auto l = run_cli("--list-devices", env);
    INFO(l.out << l.err);
    REQUIRE(l.rc == 0);
    std::vector<std::string> ids;
    std::istringstream lines(l.out);
    for (std::string line; std::getline(lines, line);)
        ids.push_back(line.substr(0, line.find(' ')));
    CHECK(ids.size() == 3);
    CHECK(l.out.find("Portable Computing Language") != std::string::npos);
    CHECK(l.out.find("llvmpipe") != std::string::npos);
    CHECK(l.out.find("Oclgrind Simulator") != std::string::npos);
    // Each one by P:D runs a small map and says which it was; auto takes
    // PoCL: the simulator calls itself a GPU, llvmpipe has no fp64.
    const fs::path small = d / "n16.exr";
    {
        std::vector<float> px(16 * 16 * 3);
        for (std::size_t i = 0; i < px.size(); i += 3) {
            px[i] = 0.1f * float(std::sin(0.3 * double(i)));
            px[i + 1] = 0.1f * float(std::cos(0.2 * double(i)));
            px[i + 2] = 0.99f;
        }
        REQUIRE(relief::test::image(16, 16, 3, px).write(small.string()));
    }
    std::vector<std::vector<float>> results;
    for (const std::string& id : ids) {
        INFO("device " << id);
        const fs::path out = d / ("h" + id.substr(0, id.find(':')) + ".exr");
        auto r = run_cli("-v --device " + id + " '" + small.string() + "' --height -o '" + out.string() + "'",
                         env + " RELIEF_CACHE_DIR=" + (d / "cache").string());
        INFO(r.err);
        REQUIRE(r.rc == 0);
        CHECK(r.err.find("device: " + id + " ") != std::string::npos);
        results.push_back(relief::test::file_pixels(out));
    }
    for (std::size_t i = 1; i < results.size(); ++i)
        CHECK(relief::test::max_abs_diff(results[0], results[i]) <= 1e-4 * relief::test::max_abs(results[0]));
    auto a = run_cli("-v '" + small.string() + "' --slopes -o '" + (d / "s.exr").string() + "'", env);
    CHECK(a.err.find("Portable Computing Language") != std::string::npos);
}
