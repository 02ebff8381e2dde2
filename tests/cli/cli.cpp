// SPDX-License-Identifier: Apache-2.0
// The relief command line: the documented example, and every bad input
// failing with a message, a non-zero exit and nothing left behind.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "relief/relief.h"
#include "support/images.h"
#include "support/run_cli.h"

namespace fs = std::filesystem;
using relief::test::max_abs_diff;
using relief::test::run_cli;
using relief::test::slurp;

using relief::test::kSampleHeight;
using relief::test::kSampleNormal;

namespace {

// Nothing named like the output, temporary files included, may remain.
bool folder_is_empty_but(const fs::path& dir, const std::string& keep = "")
{
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path().filename() != keep)
            return false;
    return true;
}

}  // namespace

TEST_CASE("cli: the documented example writes a float EXR height map with metadata", "[cli]")
{
    auto dir = relief::test::scratch("cli/example");
    auto out = dir / "height.exr";
    auto r = run_cli("'" + kSampleNormal +
                     "' --height:method=rays:impl=reference:normal=directx:rays=16:"
                     "radius=32:phase=0.5:boundary=clip -o '" +
                     out.string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    OIIO::ImageBuf h(out.string());
    REQUIRE(h.read());
    CHECK(h.spec().width == 512);
    CHECK(h.spec().nchannels == 1);
    CHECK(h.spec().format == OIIO::TypeDesc::FLOAT);
    CHECK(h.spec().get_string_attribute("relief:method") == "rays");
    CHECK(h.spec().get_string_attribute("relief:normal_convention") == "directx");
    CHECK(h.spec().get_string_attribute("relief:height_unit") == "texel");
    CHECK(h.spec().get_string_attribute("relief:parameters") ==
          "method=rays impl=reference rays=16 radius=32 phase=0.5 directions=rational "
          "boundary=clip");
    CHECK(folder_is_empty_but(dir, "height.exr"));
}

TEST_CASE("cli: -v reports device and convention, integer outputs state their scale", "[cli]")
{
    auto dir = relief::test::scratch("cli/verbose");
    const auto launched = std::chrono::steady_clock::now();
    auto r = run_cli("-v '" + kSampleNormal + "' --height:rays=8:radius=8 -o '" + (dir / "h.exr").string() +
                     "' -d uint16 -o '" + (dir / "h16.png").string() + "' -d uint8 -o '" +
                     (dir / "h8.png").string() + "' -o '" + (dir / "h8.tif").string() + "'");
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - launched).count();
    INFO(r.err);
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("device:") != std::string::npos);
    // The process's own clock: its start-up and its end, both within the
    // time the test saw it run (the kernel's ticks: 1/100 s).
    const std::size_t start_at = r.err.find("process start (loading libraries, before main): ");
    const std::size_t done_at = r.err.find("relief: done ");
    REQUIRE(start_at != std::string::npos);
    REQUIRE(done_at != std::string::npos);
    double start = -1.0, done = -1.0;
    REQUIRE(std::sscanf(r.err.c_str() + start_at, "process start (loading libraries, before main): %lf",
                        &start) == 1);
    REQUIRE(std::sscanf(r.err.c_str() + done_at, "relief: done %lf s after", &done) == 1);
    CHECK(start >= 0.0);
    CHECK(start <= done);
    CHECK(done <= wall + 0.05);
    CHECK(r.err.find("normal convention: directx") != std::string::npos);
    // What each operation was asked, in full, defaults included.
    CHECK(r.err.find("height: method=rays impl=fast rays=8 radius=8 phase=0.5 directions=rational "
                     "boundary=auto") != std::string::npos);
    CHECK(r.err.find("uint16 values v hold data = (v - 0.5) *") != std::string::npos);
    // What was read and written, each once.
    CHECK(r.err.find("relief: read " + kSampleNormal + ": ") != std::string::npos);
    for (const char* name : {"h.exr", "h16.png", "h8.png", "h8.tif"})
        CHECK(r.err.find("relief: wrote " + (dir / name).string() + "\n") != std::string::npos);
    // Without -v none of that: no read, write or progress lines.
    const auto quiet =
        run_cli("'" + kSampleNormal + "' --height --correct:scale=0.05:levels=1:iterations=3 -o '" +
                (dir / "q.exr").string() + "'");
    INFO(quiet.err);
    REQUIRE(quiet.rc == 0);
    for (const char* chatter : {"relief: read ", "relief: wrote ", "%\n", "device:"})
        CHECK(quiet.err.find(chatter) == std::string::npos);
    // With it, an operation that reports its progress says each tenth once,
    // in order, up to 100%.
    const auto steps =
        run_cli("-v '" + kSampleNormal + "' --height --correct:scale=0.05:levels=1:iterations=3 -o '" +
                (dir / "v.exr").string() + "'");
    REQUIRE(steps.rc == 0);
    std::size_t at = 0;
    for (int pct = 10; pct <= 100; pct += 10) {
        const std::size_t next = steps.err.find("relief: --correct: " + std::to_string(pct) + "%\n", at);
        INFO(pct << "% in\n" << steps.err);
        REQUIRE(next != std::string::npos);
        at = next + 1;
    }
    CHECK(steps.err.find("relief: --correct: 110%") == std::string::npos);
    CHECK(steps.err.find("relief: --correct: 0%") == std::string::npos);

    OIIO::ImageBuf f((dir / "h.exr").string()), q((dir / "h8.png").string()), tif((dir / "h8.tif").string());
    REQUIRE(tif.read());
    CHECK(tif.spec().get_string_attribute("ImageDescription").find("relief: data = (value - 0.5) *") == 0);
    REQUIRE(f.read());
    REQUIRE(q.read());
    CHECK(q.spec().format == OIIO::TypeDesc::UINT8);
    const float scale = std::stof(q.spec().get_string_attribute("relief:height_scale", "0"));
    CHECK(q.spec().get_string_attribute("relief:height_midlevel") == "0.5");
    REQUIRE(scale > 0.0f);
    float a = 0, b = 0;
    for (int i = 0; i < 50; ++i) {
        f.getpixel(i * 7, i * 5, &a, 1);
        q.getpixel(i * 7, i * 5, &b, 1);
        CHECK(std::abs((b - 0.5f) * scale - a) <= scale / 255.0f);
    }
}

TEST_CASE("cli: a read then a height sets the device up beside the read, a --dup between them or not",
          "[cli]")
{
    auto dir = relief::test::scratch("cli/ahead");
    const std::string out = "'" + (dir / "h.exr").string() + "'";
    for (const std::string& between : {std::string(), std::string(" --dup")}) {
        INFO("between: '" << between << "'");
        const auto r = run_cli("-v '" + kSampleNormal + "'" + between + " --height -o " + out);
        INFO(r.err);
        REQUIRE(r.rc == 0);
        CHECK(r.err.find("relief: set up ahead, beside the read: ") != std::string::npos);
    }
    // Not for an operation that does not set up ahead (slopes plan no FFT).
    const auto r = run_cli("-v '" + kSampleNormal + "' --slopes -o " + out);
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("set up ahead") == std::string::npos);
}

TEST_CASE("cli: --slopes pushes the 2-channel DDM and says which convention auto chose", "[cli]")
{
    auto dir = relief::test::scratch("cli/slopes");
    auto r = run_cli("'" + kSampleNormal + "' --slopes:normal=auto -o '" + (dir / "s.exr").string() + "'");
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("normal convention: directx (curl rms opengl") != std::string::npos);
    CHECK(r.err.find("device:") == std::string::npos);  // details only with -v
    OIIO::ImageBuf s((dir / "s.exr").string());
    REQUIRE(s.read());
    CHECK(s.spec().nchannels == 2);
    CHECK(s.spec().get_string_attribute("relief:normal_convention") == "directx");
}

TEST_CASE("cli: results are bit-identical whatever the PoCL thread count", "[cli]")
{
    auto dir = relief::test::scratch("cli/determinism");
    std::string a = (dir / "a.exr").string(), b = (dir / "b.exr").string();
    std::string cmd = "'" + kSampleNormal + "' --height:rays=12:radius=20:boundary=clip -o ";
    REQUIRE(run_cli(cmd + "'" + a + "'", "POCL_MAX_PTHREAD_COUNT=1").rc == 0);
    REQUIRE(run_cli(cmd + "'" + b + "'", "POCL_MAX_PTHREAD_COUNT=2").rc == 0);
    OIIO::ImageBuf ia(a), ib(b);
    REQUIRE(ia.read());
    REQUIRE(ib.read());
    std::vector<float> pa(512 * 512), pb(512 * 512);
    ia.get_pixels(ia.roi(), OIIO::TypeDesc::FLOAT, pa.data());
    ib.get_pixels(ib.roi(), OIIO::TypeDesc::FLOAT, pb.data());
    CHECK(pa == pb);
}

TEST_CASE("cli: bad input fails with a clear message, a non-zero exit and no output", "[cli][errors][slow]")
{
    auto dir = relief::test::scratch("cli/bad");
    const std::string out = "'" + (dir / "out.exr").string() + "'";
    {
        std::ofstream(dir / "empty.png");
        std::ofstream(dir / "text.png") << "this is not an image\n";
        std::string png = slurp(kSampleNormal);
        std::ofstream(dir / "truncated.png", std::ios::binary) << png.substr(0, png.size() / 3);
        OIIO::ImageBuf gray(OIIO::ImageSpec(16, 16, 1, OIIO::TypeDesc::UINT8));
        REQUIRE(gray.write((dir / "gray.png").string()));
    }
    auto in = [&](const char* name) { return "'" + (dir / name).string() + "'"; };
    struct Case {
        const char* what;
        std::string args;
        std::string env;
        const char* message;
    };
    const std::string ok = "'" + kSampleNormal + "'";
    fs::path kernels = dir / "kernels";
    fs::create_directories(kernels);
    for (const auto& f : fs::directory_iterator(RELIEF_KERNELS_DIR))
        if (f.path().extension() == ".cl" || f.path().extension() == ".h")
            fs::copy_file(f.path(), kernels / f.path().filename());
    std::ofstream(kernels / "ddm.cl") << "__kernel void ddm_slopes( { syntax error\n";
    fs::create_directories(dir / "no_vendors");

    const Case cases[] = {
        {"missing file", in("missing.png") + " --height -o " + out, "", "no such file"},
        {"empty file", in("empty.png") + " --height -o " + out, "", "empty"},
        {"truncated file", in("truncated.png") + " --height -o " + out, "", "cannot read"},
        {"not an image", in("text.png") + " --height -o " + out, "", "cannot read"},
        {"one channel", in("gray.png") + " --height -o " + out, "", "channel count 1"},
        {"unknown option", ok + " --frobnicate -o " + out, "", "unknown option"},
        {"unknown modifier", ok + " --height:colour=red -o " + out, "", "unknown modifier 'colour'"},
        {"negative rays", ok + " --height:rays=-3 -o " + out, "", "rays=-3"},
        {"rays not a number", ok + " --height:rays=lots -o " + out, "", "rays=lots"},
        {"radius garbage", ok + " --height:radius=12abc -o " + out, "", "radius=12abc"},
        {"phase out of range", ok + " --height:phase=1.5 -o " + out, "", "phase=1.5"},
        {"bad convention", ok + " --height:normal=sideways -o " + out, "", "normal=sideways"},
        {"bad method", ok + " --height:method=magic -o " + out, "", "method=magic"},
        {"ray option with poisson", ok + " --height:method=poisson:rays=8 -o " + out, "",
         "apply to method=rays"},
        {"highpass with rays", ok + " --height:rays=8:highpass=4 -o " + out, "",
         "highpass applies to method=poisson, not to rays"},
        {"fast with exact angles", ok + " --height:directions=exact -o " + out, "",
         "impl=fast needs directions=rational"},
        {"clip for poisson", ok + " --height:boundary=clip -o " + out, "", "boundary=periodic, free"},
        {"negative highpass", ok + " --height:highpass=-2 -o " + out, "", "highpass=-2"},
        {"missing mask", ok + " --height:mask=" + in("missing.png") + " -o " + out, "", "no such file"},
        {"mask size mismatch", ok + " --height:mask=" + in("gray.png") + " -o " + out, "",
         "the mask is 16x16"},
        {"alpha mask without alpha", ok + " --height:mask=alpha -o " + out, "", "4 channels"},
        {"mask with rays", ok + " --height:rays=8:mask=alpha -o " + out, "",
         "a mask applies to method=poisson, not to rays"},
        {"bad type", ok + " --height -d int7 -o " + out, "", "int7"},
        {"missing output folder", ok + " --height -o '" + (dir / "nowhere" / "h.exr").string() + "'", "",
         "does not exist"},
        {"unknown output format", ok + " --height -o '" + (dir / "h.xyz").string() + "'", "",
         "unknown image format"},
        {"output is a folder", ok + " --height -o '" + (dir / "kernels").string() + "'", "",
         "it is a folder"},
        {"input is a folder", "'" + (dir / "no_vendors").string() + "' --height -o " + out, "",
         "it is a folder"},
        {"empty stack", "--height -o " + out, "", "needs 1 image"},
        {"-o without a value", ok + " --height -o", "", "needs a value"},
        {"no OpenCL device", ok + " --height -o " + out,
         "OCL_ICD_VENDORS='" + (dir / "no_vendors").string() + "'", "no OpenCL"},
        {"no such device", ok + " --device 9:9 --height -o " + out, "",
         "no OpenCL device 9:9; the devices here: 0:0 "},
        {"kernel build failure", ok + " --height:rays=4:radius=4 -o " + out,
         "RELIEF_KERNEL_DIR='" + kernels.string() + "'", "failed to build"},
    };
    for (const Case& c : cases) {
        INFO(c.what << ": relief " << c.args);
        auto r = run_cli(c.args, c.env);
        INFO("stderr: " << r.err);
        CHECK(r.rc != 0);
        CHECK(r.rc < 128);  // an exit, not a signal
        CHECK(r.err.find("relief: error:") != std::string::npos);
        CHECK(r.err.find(c.message) != std::string::npos);
        CHECK_FALSE(fs::exists(dir / "out.exr"));
        for (const auto& e : fs::directory_iterator(dir))
            CHECK(e.path().filename().string().find("relief-tmp") == std::string::npos);
    }
}

TEST_CASE("cli: a failure never clobbers an existing output", "[cli][errors]")
{
    auto dir = relief::test::scratch("cli/clobber");
    fs::path kernels = dir / "kernels";
    fs::create_directories(kernels);
    for (const char* f : {"common.h", "ddm.cl"})
        fs::copy_file(fs::path(RELIEF_KERNELS_DIR) / f, kernels / f);
    std::ofstream(kernels / "rays_reference.cl") << "not OpenCL\n";
    std::ofstream(dir / "h.exr") << "precious";
    auto r = run_cli("'" + kSampleNormal + "' --height -o '" + (dir / "h.exr").string() + "'",
                     "RELIEF_KERNEL_DIR='" + kernels.string() + "'");
    CHECK(r.rc != 0);
    CHECK(slurp(dir / "h.exr") == "precious");
    int files = 0;
    for (const auto& e : fs::directory_iterator(dir))
        files += e.is_regular_file();
    CHECK(files == 1);
}

TEST_CASE("cli: nothing to do is a usage error, --list-devices lists", "[cli]")
{
    for (const char* args : {"", "-v", "--device cpu"}) {
        INFO("relief " << args);
        auto r = run_cli(args);
        CHECK(r.rc == 2);
        CHECK(r.err.find("Usage: relief") != std::string::npos);
    }
    auto l = run_cli("--list-devices");
    INFO(l.err);
    CHECK(l.rc == 0);
    CHECK(l.out.find("0:0  ") == 0);
    auto none = run_cli("--list-devices", "OCL_ICD_VENDORS=/nonexistent-folder");
    CHECK(none.rc == 1);
    CHECK(none.err.find("relief: error:") != std::string::npos);
}

TEST_CASE("cli: warnings are printed without -v", "[cli]")
{
    auto dir = relief::test::scratch("cli/warnings");
    // A flat 8-bit map: no curl to tell the convention by.
    REQUIRE(relief::test::image(16, 16, 3, std::vector<float>(16 * 16 * 3, 0.5f), OIIO::TypeDesc::UINT8)
                .write((dir / "flat.png").string()));
    auto r = run_cli("'" + (dir / "flat.png").string() + "' --slopes -o '" + (dir / "s.exr").string() + "'");
    CHECK(r.rc == 0);
    CHECK(r.err.find("relief: warning: normal convention is ambiguous") != std::string::npos);
}

TEST_CASE("cli: --help and --version exit 0", "[cli]")
{
    auto h = run_cli("--help");
    CHECK(h.rc == 0);
    CHECK(h.out.find("--height") != std::string::npos);
    auto v = run_cli("--version");
    CHECK(v.rc == 0);
    CHECK(v.out.rfind(std::string("relief ") + relief::version() + "\n", 0) == 0);
    // what it runs on: the libraries' versions and each OpenCL platform's
    const int oiio = OIIO::openimageio_version();
    CHECK(v.out.find("\n  OpenImageIO " + std::to_string(oiio / 10000) + "." +
                     std::to_string(oiio / 100 % 100) + "." + std::to_string(oiio % 100) + "\n") !=
          std::string::npos);
    CHECK(v.out.find("\n  OpenColorIO 2.") != std::string::npos);
    CHECK(v.out.find("\n  VkFFT 1.") != std::string::npos);
    for (const auto& d : relief::list_devices())
        CHECK(v.out.find("\n  OpenCL platform " + d.id.substr(0, d.id.find(':')) + ": " + d.platform +
                         " (OpenCL ") != std::string::npos);
}

TEST_CASE("cli: every image relief writes says so in its Software attribute", "[cli][io]")
{
    const auto d = relief::test::scratch("cli/software");
    const std::string normal = kSampleNormal;
    for (const char* name : {"h.exr", "h.png", "h.tif"}) {
        const std::string out = (d / name).string();
        REQUIRE(run_cli("'" + normal + "' --height -o '" + out + "'").rc == 0);
        auto in = OIIO::ImageInput::open(out);
        REQUIRE(in);
        CHECK(in->spec().get_string_attribute("Software") == std::string("relief ") + relief::version());
    }
}

namespace {

OIIO::ImageBuf read(const std::string& path)
{
    OIIO::ImageBuf b;
    REQUIRE(relief::read_image(b, path));
    return b;
}

// Runs relief with `args` + " -o OUT" and returns OUT's pixels.
std::vector<float> cli_result(const fs::path& dir, const std::string& args)
{
    const fs::path out = dir / "cli_result.exr";
    fs::remove(out);
    auto r = run_cli(args + " -o '" + out.string() + "'");
    INFO("relief " << args << "\n" << r.err);
    REQUIRE(r.rc == 0);
    return relief::test::file_pixels(out);
}

}  // namespace

TEST_CASE("cli: results equal the API's for the same modifiers and files", "[cli][options]")
{
    using namespace relief;
    auto dir = relief::test::scratch("cli/equals_api");
    const auto in = [](const fs::path& p) { return "'" + p.string() + "' "; };
    const int w = 64, h = 48;
    // A float normal map stored in [0, 1] (range=unsigned), RGBA with
    // weights in alpha, and a 3-channel mask whose channel 0 is the weight.
    std::vector<float> rgba(std::size_t(w) * h * 4), mask(std::size_t(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = std::size_t(y) * w + x;
            const double gx = 0.8 * std::sin(0.3 * x) + 0.2 * std::cos(0.7 * y),
                         gy = 0.5 * std::cos(0.21 * x * y / 9.0);
            const double len = std::sqrt(gx * gx + gy * gy + 1.0);
            rgba[4 * i] = float(0.5 - 0.5 * gx / len);
            rgba[4 * i + 1] = float(0.5 + 0.5 * gy / len);
            rgba[4 * i + 2] = float(0.5 + 0.5 / len);
            rgba[4 * i + 3] = (x * 7 + y * 3) % 11 == 0 ? 0.0f : 0.25f + float((x + y) % 4) / 4.0f;
            mask[3 * i] = rgba[4 * i + 3];
            mask[3 * i + 1] = 1.0f - mask[3 * i];
            mask[3 * i + 2] = 0.0f;
        }
    const fs::path normals = dir / "n_unsigned.exr", normals_png = dir / "n.png",
                   mask_file = dir / "mask.tif", heights = dir / "h.exr";
    REQUIRE(relief::test::image(w, h, 4, rgba).write(normals.string()));
    OIIO::ImageBuf png = relief::test::image(w, h, 4, rgba, OIIO::TypeDesc::UINT8);
    png.specmod().attribute("oiio:UnassociatedAlpha", 1);
    REQUIRE(png.write(normals_png.string()));
    REQUIRE(relief::test::image(w, h, 3, mask).write(mask_file.string(), OIIO::TypeDesc::UINT8));

    SlopeOptions so;
    so.normals.float_encoding = FloatEncoding::Unsigned;
    so.normals.max_angle = 40.0f;
    so.normals.convention = NormalConvention::DirectX;
    CHECK(max_abs_diff(cli_result(dir, in(normals) + "--slopes:range=unsigned:max_angle=40:normal=directx"),
                       relief::test::pixels(relief::slopes(read(normals.string()), so))) == 0.0);

    HeightOptions ho;
    ho.normals = so.normals;
    ho.method = HeightMethod::Rays;
    ho.rays = 8;
    ho.radius = 10;
    ho.phase = 0.25f;
    ho.boundary = Boundary::Free;
    const OIIO::ImageBuf api_rays = relief::height(read(normals.string()), ho);
    INFO(relief::geterror());
    REQUIRE_FALSE(api_rays.has_error());
    CHECK(max_abs_diff(cli_result(dir, in(normals) +
                                           "--height:range=unsigned:max_angle=40:normal=directx:rays=8:"
                                           "radius=10:phase=0.25:boundary=clip"),
                       relief::test::pixels(api_rays)) == 0.0);

    HeightOptions mo;
    mo.normals.convention = NormalConvention::OpenGL;
    mo.boundary = Boundary::Free;
    mo.mask_alpha = true;
    const auto by_alpha = relief::test::pixels(relief::height(read(normals_png.string()), mo));
    CHECK(max_abs_diff(cli_result(dir, in(normals_png) + "--height:normal=opengl:boundary=free:mask=alpha"),
                       by_alpha) == 0.0);
    const OIIO::ImageBuf mask_image = read(mask_file.string());
    mo.mask_alpha = false;
    mo.mask = &mask_image;
    const auto by_file = relief::test::pixels(relief::height(read(normals_png.string()), mo));
    CHECK(max_abs_diff(cli_result(dir, in(normals_png) +
                                           "--height:normal=opengl:boundary=free:mask=" + mask_file.string()),
                       by_file) == 0.0);
    CHECK(max_abs_diff(by_alpha, by_file) == 0.0);  // the same 8-bit weights
    mo.mask = nullptr;
    CHECK(relief::test::max_abs_diff(relief::test::pixels(relief::height(read(normals_png.string()), mo)),
                                     by_file) > 1e-3);

    // Correction with a fixation mask file and with a height tent.
    std::vector<float> hts(std::size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            hts[std::size_t(y) * w + x] = float(std::sin(2 * M_PI * x / w) * std::cos(2 * M_PI * 2 * y / h));
    REQUIRE(relief::test::image(w, h, 1, hts).write(heights.string()));
    CorrectOptions co;
    co.scale = 0.1f;
    co.nodes = CorrectNodes::Center;
    co.fix_mask = &mask_image;
    const auto fixed_by_file = relief::test::pixels(relief::correct(read(heights.string()), co));
    CHECK(max_abs_diff(
              cli_result(dir, in(heights) + "--correct:scale=0.1:nodes=center:fix=" + mask_file.string()),
              fixed_by_file) == 0.0);
    co.fix_mask = nullptr;
    co.fix_height = 0.5f;
    co.fix_width = 0.25f;
    const auto fixed_by_tent = relief::test::pixels(relief::correct(read(heights.string()), co));
    CHECK(max_abs_diff(cli_result(dir, in(heights) + "--correct:scale=0.1:nodes=center:fix=height:0.5:0.25"),
                       fixed_by_tent) == 0.0);
    CHECK(relief::test::max_abs_diff(fixed_by_file, fixed_by_tent) > 1e-6);
}

TEST_CASE("cli: a mask file weights the least-squares solve", "[cli][mask]")
{
    auto dir = relief::test::scratch("cli/mask");
    // Exclude the left half of the sample.
    OIIO::ImageBuf m(OIIO::ImageSpec(512, 512, 1, OIIO::TypeDesc::UINT8));
    for (int y = 0; y < 512; ++y)
        for (int x = 0; x < 512; ++x) {
            float v = x < 256 ? 0.0f : 1.0f;
            m.setpixel(x, y, &v);
        }
    REQUIRE(m.write((dir / "mask.png").string()));
    auto out = dir / "h.exr";
    auto r = run_cli("-v '" + kSampleNormal + "' --height:mask='" + (dir / "mask.png").string() + "' -o '" +
                     out.string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("conjugate-gradient iterations") != std::string::npos);
    OIIO::ImageBuf h(out.string());
    REQUIRE(h.read());
    CHECK(h.spec().get_string_attribute("relief:parameters").find("mask=image") != std::string::npos);
    // The values are the API's with the same mask, and the mask matters.
    relief::HeightOptions o;
    const OIIO::ImageBuf mask = read((dir / "mask.png").string());
    o.mask = &mask;
    const auto api = relief::test::pixels(relief::height(read(kSampleNormal), o));
    CHECK(max_abs_diff(relief::test::pixels(h), api) == 0.0);
    CHECK(relief::test::max_abs_diff(api, relief::test::pixels(relief::height(read(kSampleNormal)))) > 1e-2);
}

TEST_CASE("cli: a damaged file gives one line of relief's own, library noise only under -v", "[cli][errors]")
{
    auto dir = relief::test::scratch("cli/damaged");
    const std::string png = slurp(kSampleNormal);
    std::ofstream(dir / "truncated.png", std::ios::binary) << png.substr(0, png.size() / 3);
    {
        OIIO::ImageBuf img(OIIO::ImageSpec(64, 64, 3, OIIO::TypeDesc::UINT8));
        REQUIRE(img.write((dir / "whole.ppm").string()));
    }
    const std::string ppm = slurp(dir / "whole.ppm");
    std::ofstream(dir / "truncated.ppm", std::ios::binary) << ppm.substr(0, ppm.size() / 2);
    const std::string out = "'" + (dir / "out.exr").string() + "'";
    for (const char* name : {"truncated.png", "truncated.ppm"}) {
        INFO(name);
        auto r = run_cli("'" + (dir / name).string() + "' --height -o " + out);
        INFO("stderr: " << r.err);
        CHECK(r.rc == 1);
        CHECK(r.err.rfind("relief: error: cannot read", 0) == 0);
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);  // one line, nothing else
        CHECK(r.err.find("unknown error") == std::string::npos);
    }
    // -v passes the image library's own diagnostics through.
    auto r = run_cli("-v '" + (dir / "truncated.png").string() + "' --height -o " + out);
    INFO("stderr: " << r.err);
    CHECK(r.rc == 1);
    CHECK(r.err.find("libpng") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "out.exr"));
}

TEST_CASE("cli: a buffer larger than the device allows is refused with the numbers", "[cli][errors]")
{
    auto dir = relief::test::scratch("cli/max_alloc");
    const std::string out = "'" + (dir / "out.exr").string() + "'";
    for (const char* op : {"--height", "--height:rays=8:radius=8", "--height:boundary=free"}) {
        INFO(op);
        auto r = run_cli("'" + kSampleNormal + "' " + op + " -o " + out, "RELIEF_DEVICE_MAX_ALLOC=100000");
        INFO("stderr: " << r.err);
        CHECK(r.rc == 1);
        CHECK(r.err.find("relief: error:") != std::string::npos);
        CHECK(r.err.find("more than the device allows in one buffer (0.1 MiB, RELIEF_DEVICE_MAX_ALLOC)") !=
              std::string::npos);
        CHECK_FALSE(fs::exists(dir / "out.exr"));
    }
    // The reference kernel's walk tables are refused before they are built.
    {
        auto r = run_cli("'" + kSampleNormal + "' --height:impl=reference:rays=64:radius=4000 -o " + out,
                         "RELIEF_DEVICE_MAX_ALLOC=4000000");
        INFO("stderr: " << r.err);
        CHECK(r.rc == 1);
        CHECK(r.err.find("rays=64 and radius=4000 need walk tables of up to") != std::string::npos);
        CHECK(r.err.find("MiB, more than the device allows in one buffer (3 MiB); use impl=fast") !=
              std::string::npos);
    }
    auto r = run_cli("'" + kSampleNormal + "' --height -o " + out, "RELIEF_DEVICE_MAX_ALLOC=lots");
    CHECK(r.rc == 1);
    CHECK(r.err.find("RELIEF_DEVICE_MAX_ALLOC must be a number of bytes") != std::string::npos);
}

TEST_CASE("cli: -d half warns for offsets wider than half floats hold to 1/8 texel, not below", "[cli]")
{
    const fs::path dir = relief::test::scratch("cli/half-offsets");
    for (const int w : {2048, 2049}) {
        const std::string in = (dir / ("h" + std::to_string(w) + ".exr")).string();
        REQUIRE(relief::test::image(w, 2, 1, std::vector<float>(std::size_t(w) * 2, 0.0f)).write(in));
        const std::string out = (dir / ("o" + std::to_string(w) + ".exr")).string();
        auto r = run_cli("'" + in + "' --correct:scale=0.01 -d half -o '" + out + "'");
        INFO(r.err);
        CHECK(r.rc == 0);
        CHECK((r.err.find("half values above 2048 texels are coarser than 1/8 texel") != std::string::npos) ==
              (w > 2048));
    }
}

TEST_CASE("cli: hats=always sweeps every iteration of every level, and -v and --report say so", "[cli][slow]")
{
    auto dir = relief::test::scratch("cli/hat_sweeps");
    const std::string height = kSampleHeight;
    auto r = run_cli("-v '" + height + "' --correct:scale=10:iterations=3:hats=always:global=off -o '" +
                     (dir / "c.exr").string() + "' --report '" + (dir / "r.json").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    const std::string json = slurp(dir / "r.json");
    std::vector<double> sweeps;
    for (std::size_t at = json.find("\"hat_sweeps\": "); at != std::string::npos;
         at = json.find("\"hat_sweeps\": ", at + 1))
        sweeps.push_back(relief::test::json_number(json, "hat_sweeps", at));
    REQUIRE(sweeps.size() >= 3);
    for (double s : sweeps)
        CHECK(s == 3.0);
    std::size_t lines = 0;
    for (std::size_t at = r.err.find("3 iteration(s) and 3 hat sweep(s), energy"); at != std::string::npos;
         at = r.err.find("3 iteration(s) and 3 hat sweep(s), energy", at + 1))
        ++lines;
    CHECK(lines == sweeps.size());
    OIIO::ImageBuf c((dir / "c.exr").string());
    REQUIRE(c.read());
    CHECK(c.spec().get_string_attribute("relief:parameters").find(" hats=always") != std::string::npos);
}

TEST_CASE("cli: global=always steps after every iteration, and -v, --report and the parameters say so",
          "[cli]")
{
    auto dir = relief::test::scratch("cli/global_steps");
    const std::string height = kSampleHeight;
    auto r = run_cli("-v '" + height + "' --correct:scale=0.05:iterations=3:global=always -o '" +
                     (dir / "c.exr").string() + "' --report '" + (dir / "r.json").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    const std::string json = slurp(dir / "r.json");
    int levels = 0, stepped = 0;
    for (std::size_t at = json.find("\"global_steps\": "); at != std::string::npos;
         at = json.find("\"global_steps\": ", at + 1)) {
        const double steps = relief::test::json_number(json, "global_steps", at);
        CHECK(steps >= 0.0);
        CHECK(steps <= 3.0);
        ++levels;
        stepped += steps > 0.0;
    }
    CHECK(levels >= 3);
    CHECK(stepped >= 2);  // a step is kept only where it lowers the energy
    std::size_t lines = 0;
    for (std::size_t at = r.err.find(" global step(s), energy"); at != std::string::npos;
         at = r.err.find(" global step(s), energy", at + 1))
        ++lines;
    CHECK(lines == std::size_t(stepped));
    OIIO::ImageBuf c((dir / "c.exr").string());
    REQUIRE(c.read());
    CHECK(c.spec().get_string_attribute("relief:parameters").find(" global=always") != std::string::npos);
}

TEST_CASE(
    "cli: polish=N polishes the delivered mesh N times (2 by default), and -v, --report and the parameters "
    "say so, and polish=0 delivers the corner means",
    "[cli][slow]")
{
    auto dir = relief::test::scratch("cli/polish");
    const std::string height = kSampleHeight;
    const auto correct = [&](const std::string& polish, const std::string& name) {
        auto r = run_cli("-v '" + height + "' --correct:scale=0.05:iterations=3" + polish + " -o '" +
                         (dir / (name + ".exr")).string() + "' --report '" +
                         (dir / (name + ".json")).string() + "'");
        INFO(r.err);
        REQUIRE(r.rc == 0);
        return r.err;
    };
    const std::string said1 = correct(":polish=1", "one"), said0 = correct(":polish=0", "none"),
                      said = correct("", "default");
    const std::string json = slurp(dir / "one.json");
    const std::size_t at = json.find("\"polish\": ");
    REQUIRE(at != std::string::npos);
    CHECK(relief::test::json_number(json, "iterations", at) == 1.0);
    const double start = relief::test::json_number(json, "energy_start", at),
                 end = relief::test::json_number(json, "energy_end", at);
    CHECK(end < start);
    CHECK(said1.find("polish of the delivered texel-centre mesh: 1 iteration(s)") != std::string::npos);
    CHECK(said.find("polish of the delivered texel-centre mesh: 2 iteration(s)") != std::string::npos);
    CHECK(said0.find("polish of the delivered") == std::string::npos);
    const std::string none = slurp(dir / "none.json");
    CHECK(relief::test::json_number(none, "iterations", none.find("\"polish\": ")) == 0.0);
    std::vector<std::vector<float>> out;
    for (const char* name : {"one", "none", "default"}) {
        OIIO::ImageBuf c((dir / (std::string(name) + ".exr")).string());
        REQUIRE(c.read());
        const std::string par = c.spec().get_string_attribute("relief:parameters");
        const char* polish = name[0] == 'o' ? "1" : name[0] == 'n' ? "0" : "2";
        CHECK(par.find(std::string(" polish=") + polish) != std::string::npos);
        out.emplace_back(std::size_t(c.spec().image_pixels()) * 2);
        c.get_pixels(c.roi(), OIIO::TypeDesc::FLOAT, out.back().data());
    }
    CHECK(out[0] != out[1]);
    CHECK(out[2] != out[1]);
    CHECK(out[2] != out[0]);
    auto bad =
        run_cli("'" + height + "' --correct:scale=0.05:polish=-1 -o '" + (dir / "bad.exr").string() + "'");
    CHECK(bad.rc != 0);
    CHECK(bad.err.find("polish=-1 must be an integer in [0, 1000]") != std::string::npos);
    CHECK(!fs::exists(dir / "bad.exr"));
}

TEST_CASE("cli: -v says which share of the coarser offsets each correction level started from", "[cli]")
{
    // At scale 10 the bundled metal panel's levels start from part of the
    // coarser offsets (measured: 1/4 to 3/4); -v says it as the report
    // records it.
    auto dir = relief::test::scratch("cli/start_factor");
    const std::string height = kSampleHeight;
    auto r = run_cli("-v '" + height + "' --correct:scale=10:iterations=3 -o '" + (dir / "c.exr").string() +
                     "' --report '" + (dir / "r.json").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    const std::string json = slurp(dir / "r.json");
    std::vector<double> factors;
    for (std::size_t at = json.find("\"start_factor\": "); at != std::string::npos;
         at = json.find("\"start_factor\": ", at + 1))
        factors.push_back(relief::test::json_number(json, "start_factor", at));
    REQUIRE(factors.size() >= 3);
    CHECK(factors.front() == 0.0);  // the coarsest level starts at zero
    CHECK(*std::min_element(factors.begin() + 1, factors.end()) < 1.0);
    std::size_t from = 0;
    for (std::size_t l = 1; l < factors.size(); ++l) {
        char text[64];
        std::snprintf(text, sizeof text, "(from the coarser offsets x%g)", factors[l]);
        INFO("level " << l << ": " << text);
        from = r.err.find(text, from);
        CHECK(from != std::string::npos);
        if (from == std::string::npos)
            break;
        ++from;
    }
}
