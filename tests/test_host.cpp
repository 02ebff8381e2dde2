// Host layer: device choice and kernel build failures.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "compute_context.h"
#include "bake_stage.h"
#include "correct_stage.h"
#include "errors.h"
#include "slope_stage.h"

using namespace relief::host;

TEST_CASE("device specs: auto finds a device, malformed specs are refused", "[host]")
{
    auto devices = list_devices();
    REQUIRE_FALSE(devices.empty());
    auto chosen = choose_device("auto");
    CHECK(chosen.platform_index >= 0);
    CHECK_FALSE(chosen.describe().empty());
    auto same = choose_device(std::to_string(chosen.platform_index) + ":" +
                              std::to_string(chosen.device_index));
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

TEST_CASE("a kernel that does not compile raises KernelBuildError with the compiler's log",
          "[host][errors]")
{
    namespace fs = std::filesystem;
    fs::path dir = fs::path(RELIEF_TEST_TMP) / "broken_kernels";
    fs::create_directories(dir);
    fs::copy_file(fs::path(RELIEF_KERNELS_DIR) / "common.h", dir / "common.h",
                  fs::copy_options::overwrite_existing);
    std::ofstream(dir / "ddm.cl") << "__kernel void ddm_slopes(__global float* x) { x[0] = undeclared_name; }\n";

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
                                  BakeFilter::Bilinear, nullptr),
                      Catch::Contains("bake: a 46340x46340 map"));
    CHECK_THROWS_WITH(upload_slopes(*ctx, nullptr, 50000, 50000),
                      Catch::Contains("slopes: a 50000x50000 map"));
    CorrectParams p;
    CHECK_THROWS_WITH(correct_distortion(*ctx, nullptr, 46340, 46340, p, nullptr),
                      Catch::Contains("correct: a 46340x46340 map"));
}
