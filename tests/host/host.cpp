// SPDX-License-Identifier: Apache-2.0
// Host layer: device choice and kernel build failures.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "device/binary_cache.h"
#include "device/compute_context.h"
#include "bake/bake_stage.h"
#include "correct/correct_stage.h"
#include "device/environment.h"
#include "errors.h"
#include "device/memory_budget.h"
#include "fft/fft_plan.h"
#include "fft/plan_cache.h"
#include "poisson/poisson_stage.h"
#include "device/setup_times.h"
#include "slopes/slope_stage.h"
#include "support/run_cli.h"
#include "support/scoped_env.h"

using namespace relief::host;

TEST_CASE("device specs: auto finds a device, malformed specs are refused", "[host]")
{
    auto devices = relief::host::list_devices();
    REQUIRE_FALSE(devices.empty());
    auto chosen = choose_device("auto");
    CHECK(chosen.platform_index >= 0);
    CHECK_FALSE(chosen.describe().empty());
    auto same =
        choose_device(std::to_string(chosen.platform_index) + ":" + std::to_string(chosen.device_index));
    CHECK(same.name == chosen.name);
    // PoCL's CPU device is there wherever the tests run; "gpu" finds a GPU
    // or fails, never falling back to something else.
    const DeviceInfo cpu = choose_device("cpu");
    CHECK_FALSE(cpu.is_gpu);
    bool any_gpu = false;
    for (const auto& d : devices)
        any_gpu |= d.is_gpu;
    if (any_gpu)
        CHECK(choose_device("gpu").is_gpu);
    else
        CHECK_THROWS_AS(choose_device("gpu"), NoDeviceError);
    for (const char* bad : {"banana", "0:", ":0", "0:x", "-1:0", "1:2:3"})
        CHECK_THROWS_AS(choose_device(bad), Error);
    CHECK_THROWS_AS(choose_device("99:99"), NoDeviceError);
}

TEST_CASE("a kernel that does not compile raises KernelBuildError with the compiler's log", "[host][errors]")
{
    namespace fs = std::filesystem;
    fs::path dir = fs::path(RELIEF_TEST_TMP) / "broken_kernels";
    fs::create_directories(dir);
    fs::copy_file(fs::path(RELIEF_KERNELS_DIR) / "common.h", dir / "common.h",
                  fs::copy_options::overwrite_existing);
    std::ofstream(dir / "ddm.cl")
        << "__kernel void ddm_slopes(__global float* x) { x[0] = undeclared_name; }\n";

    ::setenv("RELIEF_KERNEL_DIR", dir.c_str(), 1);
    // A fresh context: acquire() would hand back one that already built ddm.cl.
    ComputeContext ctx(choose_device("auto"));
    try {
        ctx.build_program("ddm.cl");
        FAIL("the broken kernel built");
    } catch (const KernelBuildError& e) {
        CHECK(std::string(e.what()).find("ddm.cl") != std::string::npos);
        CHECK(e.log().find("undeclared_name") != std::string::npos);
    }
    ::unsetenv("RELIEF_KERNEL_DIR");
}

TEST_CASE("maps past the kernels' 32-bit indices are refused before any work", "[host]")
{
    // (w + 2) x (h + 2) must stay below 2^31: 46338^2 is the largest square.
    CHECK_NOTHROW(check_index_range(46338, 46338, "test"));
    CHECK_THROWS_WITH(check_index_range(46339, 46339, "test"),
                      Catch::Contains("a 46339x46339 map is larger than this version handles"));
    CHECK_THROWS_AS(check_index_range(1 << 30, 1, "test"), Error);
    // Each stage checks before it reads a pixel (null pointers: nothing is read).
    auto ctx = ComputeContext::acquire("auto");
    CHECK_THROWS_WITH(bake_gather(*ctx, nullptr, 46340, 46340, 3, nullptr, true,
                                  relief::host::BakeFilter::Bilinear, nullptr),
                      Catch::Contains("bake: a 46340x46340 map"));
    CHECK_THROWS_WITH(upload_slopes(*ctx, nullptr, 50000, 50000),
                      Catch::Contains("slopes: a 50000x50000 map"));
    CorrectParams p;
    CHECK_THROWS_WITH(correct_distortion(*ctx, nullptr, 46340, 46340, p, nullptr),
                      Catch::Contains("correct: a 46340x46340 map"));
}

namespace {

// The files of `dir`, sorted; none when it does not exist.
std::vector<std::filesystem::path> files_in(const std::filesystem::path& dir)
{
    std::vector<std::filesystem::path> v;
    if (std::filesystem::exists(dir))
        for (const auto& e : std::filesystem::directory_iterator(dir))
            v.push_back(e.path());
    std::sort(v.begin(), v.end());
    return v;
}

// Rusticl (Mesa 22.3) panics on a program binary it did not write, which
// aborts the process, instead of returning CL_INVALID_BINARY.
bool refuses_foreign_binaries_by_aborting()
{
    return choose_device("auto").platform == "rusticl";
}

}  // namespace

TEST_CASE("the program cache's folder: RELIEF_CACHE_DIR (off: none), else XDG's, else the home's",
          "[host][cache]")
{
    relief::test::ScopedEnv env;
    env.set("RELIEF_CACHE_DIR", "/tmp/own");
    env.set("XDG_CACHE_HOME", "/tmp/xdg");
    env.set("HOME", "/tmp/home");
    CHECK(BinaryCache::folder() == "/tmp/own");
    env.set("RELIEF_CACHE_DIR", "off");
    CHECK(BinaryCache::folder().empty());
    env.set("RELIEF_CACHE_DIR", "");  // empty: as unset
    CHECK(BinaryCache::folder() == "/tmp/xdg/relief");
    env.set("RELIEF_CACHE_DIR", nullptr);
    CHECK(BinaryCache::folder() == "/tmp/xdg/relief");
    env.set("XDG_CACHE_HOME", "");
    CHECK(BinaryCache::folder() == "/tmp/home/.cache/relief");
    env.set("XDG_CACHE_HOME", nullptr);
    CHECK(BinaryCache::folder() == "/tmp/home/.cache/relief");
    env.set("HOME", nullptr);
    CHECK(BinaryCache::folder().empty());  // nowhere to keep it: not kept
}

TEST_CASE("compiled programs are kept on disk and a damaged entry is rebuilt", "[host][cache]")
{
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(RELIEF_TEST_TMP) / "binary_cache";
    fs::remove_all(dir);
    relief::test::ScopedEnv cache("RELIEF_CACHE_DIR", dir.string().c_str());
    const auto entries = [&] { return files_in(dir); };
    const auto kernels = [](ComputeContext& ctx, const char* file) {
        return ctx.impl().program(file).getInfo<CL_PROGRAM_KERNEL_NAMES>();
    };
    {
        ComputeContext ctx(choose_device("auto"));
        ctx.build_program("ddm.cl");
    }
    REQUIRE(entries().size() == 1);
    const fs::path ddm = entries()[0];
    {
        ComputeContext ctx(choose_device("auto"));
        ctx.build_program("bake.cl");
    }
    REQUIRE(entries().size() == 2);
    const fs::path bake = entries()[0] == ddm ? entries()[1] : entries()[0];
    const std::string bake_entry = BinaryCache::load(bake.stem().string()).value();

    // the entry is what a fresh context uses: ddm's binary under bake's name is taken as it is
    fs::copy_file(ddm, bake, fs::copy_options::overwrite_existing);
    {
        ComputeContext ctx(choose_device("auto"));
        CHECK(kernels(ctx, "bake.cl").find("ddm_slopes") != std::string::npos);
    }
    // a damaged entry (checksum) is ignored and replaced
    {
        std::string bytes = relief::test::slurp(bake);
        bytes[bytes.size() / 2] ^= 0x5a;
        std::ofstream(bake, std::ios::binary) << bytes;
    }
    CHECK_FALSE(BinaryCache::load(bake.stem().string()).has_value());
    {
        ComputeContext ctx(choose_device("auto"));
        CHECK(kernels(ctx, "bake.cl").find("ddm_slopes") == std::string::npos);
    }
    CHECK(BinaryCache::load(bake.stem().string()).has_value());
    // an intact entry that the driver refuses: built from source, stored anew
    // (Rusticl 22.3 aborts the process on a binary it did not write, a Rust
    // panic inside clCreateProgramWithBinary; relief's entries are keyed by
    // the driver's version, so only a hand-made entry meets that)
    if (!refuses_foreign_binaries_by_aborting()) {
        BinaryCache::store(bake.stem().string(), "not a program binary");
        {
            ComputeContext ctx(choose_device("auto"));
            CHECK(kernels(ctx, "bake.cl").find("ddm_slopes") == std::string::npos);
        }
        CHECK(BinaryCache::load(bake.stem().string()).value() != "not a program binary");
    }
    CHECK(entries().size() == 2);  // no temporary files left behind

    // off: nothing stored
    fs::remove_all(dir);
    cache.set("RELIEF_CACHE_DIR", "off");
    {
        ComputeContext ctx(choose_device("auto"));
        ctx.build_program("ddm.cl");
    }
    CHECK_FALSE(fs::exists(dir));
    CHECK(bake_entry.size() > 0);
}

TEST_CASE("VkFFT's programs are kept on disk too, and an unusable entry falls back to source",
          "[host][cache]")
{
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(RELIEF_TEST_TMP) / "vkfft_cache";
    fs::remove_all(dir);
    relief::test::ScopedEnv cache("RELIEF_CACHE_DIR", dir.string().c_str());
    const auto entries = [&] { return files_in(dir); };
    // A round trip of a ramp through a fresh context's 64 x 48 plan (VkFFT's
    // 2-D path: its programs only); the transformed values, to compare bits.
    const auto transform = [] {
        ComputeContext ctx(choose_device("auto"));
        auto& c = ctx.impl();
        const std::size_t stride = FftPlan::row_stride(64);
        std::vector<float> x(stride * 48, 0.0f), y(x.size());
        for (std::size_t r = 0; r < 48; ++r)
            for (std::size_t i = 0; i < 64; ++i)
                x[r * stride + i] = float(std::sin(0.1 * double(i) + 0.3 * double(r)));
        cl::Buffer buf(c.context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(float) * x.size(),
                       x.data());
        FftPlan plan(c, 64, 48, buf);
        plan.forward(buf);
        c.queue.enqueueReadBuffer(buf, CL_TRUE, 0, sizeof(float) * y.size(), y.data());
        return y;
    };
    const std::size_t loaded = vkfft_programs_from_cache();
    const std::vector<float> first = transform();
    CHECK(vkfft_programs_from_cache() == loaded);  // (an empty cache)
    const std::vector<fs::path> vkfft = entries();
    REQUIRE(vkfft.size() >= 2);  // forward and inverse, at least
    std::vector<std::string> stamps;
    for (const fs::path& p : vkfft)
        stamps.push_back(relief::test::slurp(p));
    CHECK(transform() == first);  // from the binaries: the same bits, nothing rebuilt
    CHECK(vkfft_programs_from_cache() >= loaded + vkfft.size());  // (each program made from its binary)
    CHECK(entries() == vkfft);
    for (std::size_t i = 0; i < vkfft.size(); ++i)
        CHECK(relief::test::slurp(vkfft[i]) == stamps[i]);

    // entries the driver refuses: built from source, stored anew
    if (!refuses_foreign_binaries_by_aborting()) {
        for (const fs::path& p : vkfft)
            BinaryCache::store(p.stem().string(), "not a program binary");
        CHECK(transform() == first);
        for (const fs::path& p : vkfft)
            CHECK(BinaryCache::load(p.stem().string()).value() != "not a program binary");
    }
    // entries the driver takes but VkFFT cannot use (another program's
    // binary, with no VkFFT_main): dropped, planned from source
    {
        ComputeContext ctx(choose_device("auto"));
        ctx.build_program("ddm.cl");
    }
    fs::path ddm;
    for (const fs::path& p : entries())
        if (std::find(vkfft.begin(), vkfft.end(), p) == vkfft.end())
            ddm = p;
    REQUIRE_FALSE(ddm.empty());
    for (const fs::path& p : vkfft)
        fs::copy_file(ddm, p, fs::copy_options::overwrite_existing);
    CHECK(transform() == first);
    CHECK(transform() == first);  // and the next plan from the entries stored anew
    for (const fs::path& p : vkfft)
        CHECK(relief::test::slurp(p) != relief::test::slurp(ddm));
}

TEST_CASE("plans are kept by kind and size, the least recently used dropped first", "[host][cache][slow]")
{
    auto ctx = ComputeContext::acquire("auto");
    auto& c = ctx->impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    const std::size_t b64x48 = sizeof(float) * FftPlan::row_stride(64) * 48;
    const std::size_t b48x64 = sizeof(float) * FftPlan::row_stride(48) * 64;
    // room for the first three plans below (each counted twice: plan buffer and work)
    PlanCache cache(2 * b48x64, 2 * (2 * b64x48 + b48x64));
    cl::Buffer scratch(c.context, CL_MEM_READ_WRITE, sizeof(float) * FftPlan::row_stride(128) * 128);
    const auto a = cache.fft(c, 64, 48, scratch);
    CHECK(cache.fft(c, 64, 48, scratch) == a);
    const auto d = cache.dct(c, 64, 48);
    CHECK(cache.dct(c, 64, 48) == d);
    const auto t = cache.fft(c, 48, 64, scratch);  // the other orientation is another plan
    CHECK(t != a);
    CHECK(cache.size() == 3);
    CHECK(cache.fft(c, 64, 48, scratch) == a);  // a is now the most recent; d the least
    const auto e = cache.fft(c, 32, 32, scratch);
    CHECK(cache.size() == 3);
    CHECK(cache.dct(c, 64, 48) != d);  // d was dropped (and still works for whoever holds it)
    // too large to keep: built against the caller's buffer, every time
    const auto big = cache.fft(c, 128, 128, scratch);
    CHECK(cache.fft(c, 128, 128, scratch) != big);
    CHECK(cache.size() == 3);

    // a kept plan transforms any buffer of its size: round trip of a ramp
    std::vector<float> x(FftPlan::row_stride(64) * 48, 0.0f), y(x.size());
    for (std::size_t r = 0; r < 48; ++r)
        for (std::size_t i = 0; i < 64; ++i)
            x[r * FftPlan::row_stride(64) + i] = float(i + 3 * r);
    cl::Buffer buf(c.context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(float) * x.size(), x.data());
    a->forward(buf);
    a->inverse(buf);
    c.queue.enqueueReadBuffer(buf, CL_TRUE, 0, sizeof(float) * y.size(), y.data());
    double worst = 0;
    for (std::size_t r = 0; r < 48; ++r)
        for (std::size_t i = 0; i < 64; ++i)
            worst = std::max(worst, double(std::abs(y[r * FftPlan::row_stride(64) + i] -
                                                    x[r * FftPlan::row_stride(64) + i])));
    CHECK(worst < 1e-3);
    CHECK(e != nullptr);
}

TEST_CASE("environment sizes: K, M, G, T alone or with iB are powers of 1024, with B of 1000, anything else "
          "is refused",
          "[host][errors]")
{
    const char* name = "RELIEF_TEST_SIZE";
    const struct {
        const char* text;
        std::uint64_t bytes;
        bool binary;
    } sizes[] = {{"1000", 1000, false},      {"2k", 2048, true},           {"2K", 2048, true},
                 {"3m", 3ull << 20, true},   {"3M", 3ull << 20, true},     {"1.5G", 3ull << 29, true},
                 {"1g", 1ull << 30, true},   {"2T", 2ull << 40, true},     {"0.5t", 1ull << 39, true},
                 {"2KiB", 2048, true},       {"3MiB", 3ull << 20, true},   {"1GiB", 1ull << 30, true},
                 {"2TiB", 2ull << 40, true}, {"1KB", 1000, false},         {"2kB", 2000, false},
                 {"3MB", 3000000, false},    {"1.5GB", 1500000000, false}, {"2TB", 2000000000000ull, false}};
    for (const auto& s : sizes) {
        INFO(s.text);
        ::setenv(name, s.text, 1);
        CHECK(size_from_environment(name) == s.bytes);
        const SizeSetting given = size_setting_from_environment(name);
        CHECK(given.bytes == s.bytes);
        CHECK(given.binary == s.binary);
        CHECK(given.text == s.text);
    }
    for (const char* bad :
         {"1P", "1Kb", "1KiBs", "1iB", "1B", "K", "-1M", "0", "0.1", "1e30T", "12 M", "nan"}) {
        INFO(bad);
        ::setenv(name, bad, 1);
        CHECK_THROWS_WITH(size_from_environment(name), Catch::Contains("RELIEF_TEST_SIZE must be a size"));
    }
    ::unsetenv(name);
    CHECK(size_from_environment(name) == 0);
    CHECK(size_setting_from_environment(name).text.empty());
}

TEST_CASE("memory: sizes said in decimal units, or in the binary ones RELIEF_MEMORY_LIMIT was given in",
          "[host]")
{
    CHECK(format_bytes(999) == "1 kB");
    CHECK(format_bytes(13600000) == "13.6 MB");
    CHECK(format_bytes(2100000000) == "2.1 GB");
    CHECK(format_bytes(3000000000000ull) == "3.0 TB");
    CHECK(format_bytes(10ull << 20, true) == "10.0 MiB");
    CHECK(format_bytes(2048, true) == "2 KiB");
    CHECK(format_bytes(3ull << 30, true) == "3.0 GiB");
    CHECK(format_bytes(5ull << 40, true) == "5.0 TiB");
    relief::test::ScopedEnv env("RELIEF_MEMORY_LIMIT", "10M");
    CHECK(refuse_host(13ull << 20) == "needs 13.0 MiB of memory, RELIEF_MEMORY_LIMIT=10M allows 10.0 MiB");
    CHECK(refuse_host(10ull << 20).empty());
    env.set("RELIEF_MEMORY_LIMIT", "10MB");
    CHECK(refuse_host(13600000) == "needs 13.6 MB of memory, RELIEF_MEMORY_LIMIT=10MB allows 10.0 MB");
    env.set("RELIEF_MEMORY_LIMIT", nullptr);
    CHECK(refuse_host(~0ull / 2).find("of memory, this machine has ") != std::string::npos);
    // a limit above what the machine has: the machine is the bound, and said
    env.set("RELIEF_MEMORY_LIMIT", "1000T");
    const std::string above = refuse_host(~0ull / 2);
    CHECK(above.find("of memory, this machine has ") != std::string::npos);
    CHECK(above.find("RELIEF_MEMORY_LIMIT") == std::string::npos);
}

TEST_CASE("memory: a cgroup's limit less its use, the tightest of the group and the groups above it",
          "[host]")
{
    namespace fs = std::filesystem;
    const fs::path d = fs::path(RELIEF_TEST_TMP) / "cgroups";
    fs::remove_all(d);
    const fs::path sys = d / "sys";
    const auto put = [](const fs::path& p, const std::string& text) {
        fs::create_directories(p.parent_path());
        std::ofstream(p) << text;
    };
    const fs::path proc = d / "cgroup";
    put(proc, "12:cpu,cpuacct:/elsewhere\n0::/farm/job7\n");
    // job7: 1000000 - (400000 - 100000 reclaimable) = 700000 left
    put(sys / "farm/job7/memory.max", "1000000\n");
    put(sys / "farm/job7/memory.current", "400000\n");
    put(sys / "farm/job7/memory.stat", "anon 290000\ninactive_file 100000\nactive_file 10000\n");
    // farm, above it: 900000 - 850000 = 50000 left, the tighter
    put(sys / "farm/memory.max", "900000\n");
    put(sys / "farm/memory.current", "850000\n");
    CHECK(cgroup_available(proc, sys) == 50000);
    put(sys / "farm/memory.max", "max\n");
    CHECK(cgroup_available(proc, sys) == 700000);
    put(sys / "farm/job7/memory.current", "1200000\n");  // over its limit: nothing left
    CHECK(cgroup_available(proc, sys) == 0);
    // a group's name may hold "0::" (only '/' and newlines are reserved):
    // the line is the v2 one by its start
    put(proc, "0::/farm/job7/step0::1\n");
    put(sys / "farm/job7/step0::1/memory.max", "300000\n");
    put(sys / "farm/job7/step0::1/memory.current", "100000\n");
    put(sys / "farm/job7/memory.current", "400000\n");
    CHECK(cgroup_available(proc, sys) == 200000);
    put(proc, "12:cpu,cpuacct:/elsewhere\n0::/farm/job7\n");
    // no limit anywhere, the root group, or no cgroup v2 line: unlimited
    const Bytes unlimited = ~Bytes(0);
    put(sys / "farm/job7/memory.max", "max\n");
    CHECK(cgroup_available(proc, sys) == unlimited);
    put(proc, "0::/\n");
    CHECK(cgroup_available(proc, sys) == unlimited);
    put(proc, "4:memory:/farm/job7\n");
    CHECK(cgroup_available(proc, sys) == unlimited);
    // the walk stops at the root it was given: a limit above it is not this tree's
    put(proc, "0::/farm/job7\n");
    put(d / "memory.max", "1\n");
    CHECK(cgroup_available(proc, sys) == unlimited);
}

TEST_CASE("memory: a need of exactly the device's memory fits it, a byte more does not", "[host]")
{
    auto ctx = ComputeContext::acquire("auto");
    const Bytes total = device_memory(*ctx).total;
    const auto refusal = [&](Bytes device) {
        try {
            check_memory(*ctx, "the test", device, 0);
        } catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    // (the host's memory may refuse the same bytes; only the device's check is asked here)
    CHECK(refusal(total).find("of device memory") == std::string::npos);
    CHECK_THAT(refusal(total + 1), Catch::Contains("the test needs") && Catch::Contains("of device memory"));
}

TEST_CASE(
    "setup times: a nested timer's time is its own kind's, not its parent's too, and ahead time is apart",
    "[host]")
{
    using std::chrono::milliseconds;
    const auto delta = [](const relief::host::SetupTimes& a, const relief::host::SetupTimes& b) {
        return relief::host::SetupTimes{b.device - a.device, b.programs - a.programs, b.plans - a.plans,
                                        b.prepared - a.prepared};
    };
    const relief::host::SetupTimes t0 = relief::host::setup_times();
    {
        SetupTimer plan(SetupTimer::Kind::Plans);
        std::this_thread::sleep_for(milliseconds(10));
        {
            SetupTimer build(SetupTimer::Kind::Programs);
            std::this_thread::sleep_for(milliseconds(300));
        }
    }
    const relief::host::SetupTimes d = delta(t0, relief::host::setup_times());
    CHECK(d.programs >= 0.3);
    CHECK(d.plans >= 0.01);
    CHECK(d.plans < d.programs / 2);  // not 0.31: the build inside is the build's
    CHECK(d.device == 0.0);
    CHECK(d.prepared == 0.0);
    const relief::host::SetupTimes t1 = relief::host::setup_times();
    std::thread([] {
        Ahead ahead;
        SetupTimer device(SetupTimer::Kind::Device);
        std::this_thread::sleep_for(milliseconds(20));
    }).join();
    const relief::host::SetupTimes a = delta(t1, relief::host::setup_times());
    CHECK(a.prepared >= 0.02);
    CHECK(a.device == 0.0);
}

TEST_CASE("prepare: a one-texel-wide map's plan is the one its height uses", "[host][cache]")
{
    // The Poisson stage lays a 1 x N map out as N x 1: set-up ahead must
    // plan that (not N x N), so the height finds it made.
    auto ctx = ComputeContext::acquire("auto");
    const int n = 397;  // (a size no other test plans)
    prepare_height(*ctx, 1, n);
    const std::size_t prepared = ctx->impl().plans->size();
    CHECK(ctx->impl().plans->keeps(std::size_t(n), 1));
    std::vector<float> slopes(2 * std::size_t(n), 0.01f);
    auto s = upload_slopes(*ctx, slopes.data(), 1, n);
    PoissonParams p;
    p.boundary_x = p.boundary_y = PoissonBoundary::Free;
    std::vector<float> out(n);
    integrate_poisson(*ctx, s, p, out.data());
    CHECK(ctx->impl().plans->size() == prepared);  // found, not made again
}
