// SPDX-License-Identifier: Apache-2.0
// Files: writes that fail half-way (file size limit, as on a full disk)
// leave the old file untouched and no temporary file behind, through the
// API and the command line (images and the --report file); --compression
// and -d reach the file; PNG alpha is read unassociated.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "device/compute_context.h"
#include "device/memory_budget.h"
#include "relief/relief.h"
#include "text_file.h"
#include "support/images.h"
#include "support/run_cli.h"

namespace fs = std::filesystem;
using relief::test::run_cli;
using relief::test::slurp;

using relief::test::kSampleNormal;

namespace {

// The names in `dir` other than `keep`.
std::vector<std::string> others(const fs::path& dir, const std::string& keep)
{
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path().filename() != keep)
            names.push_back(e.path().filename().string());
    return names;
}

// Runs the hidden test case `child` in a fresh process (fork and exec:
// a forked copy of a process with OpenCL and OIIO threads may deadlock)
// whose files may not grow beyond `limit` bytes, with SIGXFSZ ignored so
// that writes fail with EFBIG as they would with ENOSPC on a full disk.
// `arg` reaches the child as $RELIEF_TEST_CHILD_ARG. Returns its exit
// code: 0 when the write failed cleanly, 1 when it succeeded.
int with_size_limit(rlim_t limit, const std::string& child, const std::string& arg)
{
    const pid_t pid = ::fork();
    if (pid == 0) {
        std::signal(SIGXFSZ, SIG_IGN);
        const rlimit rl{limit, limit};
        if (::setrlimit(RLIMIT_FSIZE, &rl) != 0 || ::setenv("RELIEF_TEST_CHILD_ARG", arg.c_str(), 1) != 0)
            ::_exit(3);
        ::execl("/proc/self/exe", "relief_tests", child.c_str(), "--out", "/dev/null", nullptr);
        ::_exit(4);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 100 + WTERMSIG(status);
}

// The child's argument, or null when the test runs on its own (then it
// does nothing).
const char* child_arg()
{
    const char* a = std::getenv("RELIEF_TEST_CHILD_ARG");
    return a && *a ? a : nullptr;
}

}  // namespace

TEST_CASE("io: (child) write a 256x256 relief result to $RELIEF_TEST_CHILD_ARG", "[.][io-child]")
{
    const char* path = child_arg();
    if (!path)
        return;
    std::vector<float> px(256 * 256);
    for (std::size_t i = 0; i < px.size(); ++i)
        px[i] = float(std::sin(0.37 * double(i)) * 10.0);  // incompressible
    OIIO::ImageBuf img = relief::test::image(256, 256, 1, px);
    img.specmod().attribute("relief:method", "poisson");
    img.specmod().attribute("relief:height_unit", "texel");
    relief::WriteOptions o;
    const std::string ext = fs::path(path).extension().string();
    o.format = ext == ".png" ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::FLOAT;
    o.compression = ext == ".png" ? "" : "none";
    std::_Exit(relief::write_image(img, path, o) ? 1 : 0);
}

namespace {

// Writes dir/name through the child test case `child` under a file-size
// limit of `limit` bytes: the old contents `old` must survive, with no
// temporary left; without the limit the same write must succeed and leave
// no temporary either. Returns what it wrote.
std::string write_on_full_disk(const fs::path& dir, const std::string& child, const char* name, rlim_t limit,
                               const std::string& old)
{
    const fs::path target = dir / name;
    std::ofstream(target, std::ios::binary) << old;
    CHECK(with_size_limit(limit, child, target.string()) == 0);
    CHECK(slurp(target) == old);
    CHECK(others(dir, name).empty());
    CHECK(with_size_limit(RLIM_INFINITY, child, target.string()) == 1);
    const std::string written = slurp(target);
    CHECK(others(dir, name).empty());
    fs::remove(target);
    return written;
}

}  // namespace

TEST_CASE("io: a write that fails half-way keeps the old file and leaves no temporary", "[io][errors]")
{
    const auto dir = relief::test::scratch("io/partial");
    const std::string child = "io: (child) write a 256x256 relief result to $RELIEF_TEST_CHILD_ARG";
    for (const char* name : {"h.exr", "h.tif", "h.png"}) {
        INFO(name);
        const std::string old = "the previous version of this file, which must survive\n";
        // 256x256 pixels need 128 KiB and more; 20 KiB is not enough.
        // Without the limit the same write succeeds and replaces the file.
        CHECK(write_on_full_disk(dir, child, name, 20 * 1024, old) != old);
    }
}

TEST_CASE("io: (child) write 4 KiB of text to $RELIEF_TEST_CHILD_ARG", "[.][io-child]")
{
    const char* path = child_arg();
    if (!path)
        return;
    try {
        relief::cli::write_text_atomically(path, std::string(4096, 'x'), "the report");
        std::_Exit(1);
    } catch (const std::runtime_error& e) {
        // 0 only with the message the CLI prints.
        const std::string expected = "the report: cannot write '" + std::string(path) + "': ";
        std::_Exit(std::string(e.what()).rfind(expected, 0) == 0 ? 0 : 5);
    }
}

TEST_CASE("io: (child) write a mesh to $RELIEF_TEST_CHILD_ARG", "[.][io-child]")
{
    const char* path = child_arg();
    if (!path)
        return;
    // About 1 MB in every format; no device needed.
    relief::Mesh m;
    for (int i = 0; i < 30000; ++i) {
        m.positions.insert(m.positions.end(), {float(i), float(i % 7), 0.5f});
        m.normals.insert(m.normals.end(), {0.0f, 0.0f, 1.0f});
        m.texcoords.insert(m.texcoords.end(), {0.25f, 0.75f});
    }
    for (std::uint32_t t = 0; t + 2 < 30000; ++t)
        m.triangles.insert(m.triangles.end(), {t, t + 1, t + 2});
    if (relief::write_mesh(m, path))
        std::_Exit(1);
    std::_Exit(relief::geterror().find("cannot write '" + std::string(path) + "'") == 0 ? 0 : 5);
}

TEST_CASE("io: a full disk during a mesh write keeps the old file, in every format",
          "[io][errors][mesh][slow]")
{
    const auto dir = relief::test::scratch("io/mesh");
    const std::string child = "io: (child) write a mesh to $RELIEF_TEST_CHILD_ARG";
    for (const char* name : {"m.obj", "m.ply", "m.gltf", "m.glb"}) {
        INFO(name);
        CHECK(write_on_full_disk(dir, child, name, 64 * 1024, "precious\n").size() > 500000);
    }
}

TEST_CASE("io: the --report writer keeps the old file when the disk is full", "[io][errors]")
{
    const auto dir = relief::test::scratch("io/text");
    const fs::path target = dir / "r.json";
    const std::string old = "{\"old\": true}\n";
    std::ofstream(target, std::ios::binary) << old;
    const std::string child = "io: (child) write 4 KiB of text to $RELIEF_TEST_CHILD_ARG";
    CHECK(with_size_limit(1024, child, target.string()) == 0);
    CHECK(slurp(target) == old);
    CHECK(others(dir, "r.json").empty());
    CHECK(with_size_limit(RLIM_INFINITY, child, target.string()) == 1);
    CHECK(slurp(target) == std::string(4096, 'x'));
    CHECK(others(dir, "r.json").empty());
}

TEST_CASE("cli: a full disk during -o keeps the old file, exit 1", "[cli][io][errors]")
{
    const auto dir = relief::test::scratch("io/cli_partial");
    const std::string old = "precious\n";
    // dash's ulimit -f counts 512-byte blocks; an ignored SIGXFSZ is inherited.
    // PoCL writes temporary files of a few MiB when it loads kernels (even
    // from its cache): 16 MiB holds those but not the 32 MiB of slopes of a
    // 2048^2 map (a flat 8-bit PNG of a few KiB).
    const std::string limited = "trap '' XFSZ; ulimit -f 32768;";
    OIIO::ImageBuf flat =
        relief::test::image(2048, 2048, 3, std::vector<float>(2048 * 2048 * 3, 0.5f), OIIO::TypeDesc::UINT8);
    const fs::path input = dir / "flat.png";
    REQUIRE(flat.write(input.string()));
    {
        const std::string args = "'" + input.string() + "' --slopes:normal=opengl -o '";
        REQUIRE(run_cli(args + (dir / "warm.exr").string() + "'").rc == 0);
        fs::remove(dir / "warm.exr");
        std::ofstream(dir / "h.exr", std::ios::binary) << old;
        auto r = run_cli(args + (dir / "h.exr").string() + "'", limited);
        INFO(r.err);
        CHECK(r.rc == 1);
        CHECK(r.err.find("relief: error: cannot write") != std::string::npos);
        CHECK(slurp(dir / "h.exr") == old);
        CHECK(others(dir, "h.exr") == std::vector<std::string>{"flat.png"});
    }
}

TEST_CASE("cli: --compression and -d reach the file", "[cli][io]")
{
    const auto dir = relief::test::scratch("io/formats");
    auto r = run_cli("'" + kSampleNormal + "' --height:normal=directx -o '" + (dir / "plain.exr").string() +
                     "' --compression zip -o '" + (dir / "zip.exr").string() +
                     "' --compression piz -d half -o '" + (dir / "piz_half.exr").string() +
                     "' -d uint16 -o '" + (dir / "h16.tif").string() + "' -d uint8 -o '" +
                     (dir / "h8.tif").string() + "' -d float -o '" + (dir / "float_asked.png").string() +
                     "' -d half -o '" + (dir / "half_asked.png").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    struct Expect {
        const char* file;
        OIIO::TypeDesc format;
        const char* compression;  // nullptr: not checked
    };
    for (const Expect& e :
         {Expect{"plain.exr", OIIO::TypeDesc::FLOAT, "none"}, Expect{"zip.exr", OIIO::TypeDesc::FLOAT, "zip"},
          Expect{"piz_half.exr", OIIO::TypeDesc::HALF, "piz"},
          Expect{"h16.tif", OIIO::TypeDesc::UINT16, nullptr},
          Expect{"h8.tif", OIIO::TypeDesc::UINT8, nullptr},
          // PNG has no float pixels: 16 bits rather than 8.
          Expect{"float_asked.png", OIIO::TypeDesc::UINT16, nullptr},
          Expect{"half_asked.png", OIIO::TypeDesc::UINT16, nullptr}}) {
        INFO(e.file);
        OIIO::ImageBuf b((dir / e.file).string());
        REQUIRE(b.read());
        CHECK(b.spec().format == e.format);
        if (e.compression)
            CHECK(b.spec().get_string_attribute("compression") == e.compression);
    }
    // The same heights in every file (within each type's precision).
    const auto f = relief::test::file_pixels(dir / "plain.exr");
    CHECK(relief::test::file_pixels(dir / "zip.exr") == f);
    const double spread = relief::test::max_abs(f);
    CHECK(relief::test::max_abs_diff(relief::test::file_pixels(dir / "piz_half.exr"), f) < 1e-3 * spread);
    // Integer files: data = (value - 0.5) * scale.
    for (const char* name : {"h16.tif", "h8.tif", "float_asked.png", "half_asked.png"}) {
        OIIO::ImageBuf q((dir / name).string());
        REQUIRE(q.read(0, 0, true, OIIO::TypeDesc::FLOAT));
        const std::string desc = q.spec().get_string_attribute("ImageDescription");
        const std::string key = "relief: data = (value - 0.5) * ";
        REQUIRE(desc.rfind(key, 0) == 0);
        const double scale = std::stod(desc.substr(key.size()));
        CHECK(scale == Approx(2.0 * spread).epsilon(1e-6));
        auto v = relief::test::pixels(q);
        for (float& x : v)
            x = float((x - 0.5) * scale);
        const double step = std::string(name) == "h8.tif" ? 255.0 : 65535.0;
        CHECK(relief::test::max_abs_diff(v, f) <= 0.5 * scale / step * 1.01);
    }
}

TEST_CASE("io: PNG alpha is read unassociated (RGB not premultiplied)", "[io]")
{
    const auto dir = relief::test::scratch("io/alpha");
    const int w = 8, h = 4;
    std::vector<float> px(std::size_t(w) * h * 4);
    for (int i = 0; i < w * h; ++i) {
        px[4 * i + 0] = 0.8f;
        px[4 * i + 1] = 0.4f;
        px[4 * i + 2] = 1.0f;
        px[4 * i + 3] = float(i % 5) / 4.0f;  // alpha 0 .. 1
    }
    OIIO::ImageBuf out = relief::test::image(w, h, 4, px, OIIO::TypeDesc::UINT8);
    out.specmod().attribute("oiio:UnassociatedAlpha", 1);
    REQUIRE(out.write((dir / "n.png").string()));
    OIIO::ImageBuf in;
    REQUIRE(relief::read_image(in, (dir / "n.png").string()));
    CHECK(in.nativespec().format == OIIO::TypeDesc::UINT8);
    const auto got = relief::test::pixels(in);
    REQUIRE(got.size() == px.size());
    for (std::size_t i = 0; i < px.size(); ++i)
        REQUIRE(std::abs(got[i] - std::round(px[i] * 255.0f) / 255.0f) < 1e-6);
}

TEST_CASE("io: maps stay in their file's pixel type in memory (8-bit, 16-bit, half)", "[io][memory]")
{
    const auto dir = relief::test::scratch("io/native");
    const std::vector<float> px(4 * 3 * 3, 0.5f);
    for (const auto& [name, type] :
         {std::pair{"n8.png", OIIO::TypeDesc::UINT8}, std::pair{"n16.png", OIIO::TypeDesc::UINT16},
          std::pair{"nh.exr", OIIO::TypeDesc::HALF}}) {
        INFO(name);
        OIIO::ImageBuf out = relief::test::image(4, 3, 3, px, type);
        REQUIRE(out.write((dir / name).string()));
        OIIO::ImageBuf in;
        REQUIRE(relief::read_image(in, (dir / name).string()));
        // in memory as stored: an RGB 8-bit map is 3 bytes a texel, not 12
        CHECK(in.spec().format == type);
        CHECK(relief::test::max_abs_diff(relief::test::pixels(in), px) <= 0.5 / 255 + 1e-6);
    }
}

TEST_CASE("io: a header claiming more pixels than memory holds is refused before reading",
          "[io][memory][errors]")
{
    const auto dir = relief::test::scratch("io/huge-header");
    // An 8-bit RGB PNG that says it is 60000 x 60000 (10.8 GB): a valid
    // header and no image data.
    OIIO::ImageBuf small = relief::test::image(2, 2, 3, std::vector<float>(12, 0.5f), OIIO::TypeDesc::UINT8);
    REQUIRE(small.write((dir / "small.png").string()));
    std::string bytes = slurp(dir / "small.png");
    REQUIRE(bytes.substr(12, 4) == "IHDR");
    auto be32 = [](std::string& s, std::size_t at, std::uint32_t v) {
        for (int i = 0; i < 4; ++i)
            s[at + i] = char((v >> (24 - 8 * i)) & 0xff);
    };
    be32(bytes, 16, 60000);
    be32(bytes, 20, 60000);
    // the header's CRC over "IHDR" and its 13 bytes, so that it is valid
    std::uint32_t crc = 0xffffffffu;
    for (std::size_t i = 12; i < 12 + 17; ++i) {
        crc ^= std::uint8_t(bytes[i]);
        for (int k = 0; k < 8; ++k)
            crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    be32(bytes, 29, crc ^ 0xffffffffu);
    std::ofstream(dir / "huge.png", std::ios::binary) << bytes;

    auto r = run_cli("'" + (dir / "huge.png").string() + "' --height -o '" + (dir / "h.exr").string() + "'",
                     "RELIEF_MEMORY_LIMIT=2G");
    CHECK(r.rc == 1);
    CHECK(r.err.find("relief: error: cannot read '") != std::string::npos);
    CHECK(r.err.find("needs 10.1 GiB of memory, RELIEF_MEMORY_LIMIT=2G allows 2.0 GiB") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "h.exr"));
}

TEST_CASE("cli: a height that does not fit is refused with the numbers, before it starts",
          "[cli][memory][errors]")
{
    const auto dir = relief::test::scratch("io/memory-limit");
    const std::string normal = kSampleNormal;  // 512 x 512
    const std::string out = (dir / "h.exr").string();
    // The map (0.8 MB) is read; its slopes (2.1 MB) and grids are not made.
    // RELIEF_MEMORY_LIMIT bounds host memory: on a device with memory of
    // its own (a GPU) the grids live there, and the same command fits.
    namespace host = relief::host;
    const bool unified = host::device_memory(*host::ComputeContext::acquire("auto")).host_unified;
    relief::test::CliResult r;
    if (unified) {
        r = run_cli("'" + normal + "' --height:boundary=periodic -o '" + out + "'", "RELIEF_MEMORY_LIMIT=3M");
        CHECK(r.rc == 1);
        CHECK(r.err.find("relief: error: height: the Poisson integration of a 512x512 map needs ") !=
              std::string::npos);
        CHECK(r.err.find("of memory, RELIEF_MEMORY_LIMIT=3M allows 3.0 MiB") != std::string::npos);
        CHECK(r.err.find("rays") == std::string::npos);
        CHECK_FALSE(fs::exists(out));
        r = run_cli("'" + normal + "' --height:method=rays:boundary=periodic -o '" + out + "'",
                    "RELIEF_MEMORY_LIMIT=3M");
        CHECK(r.rc == 1);
        CHECK(r.err.find("relief: error: height: ray integration of a 512x512 map needs ") !=
              std::string::npos);
        CHECK_FALSE(fs::exists(out));
    } else {
        WARN("the test device has memory of its own: 3 MB of host memory is not reached");
    }
    // with room, the same commands run
    r = run_cli("'" + normal + "' --height:boundary=periodic -o '" + out + "'", "RELIEF_MEMORY_LIMIT=64M");
    CHECK(r.rc == 0);
    CHECK(fs::exists(out));
    r = run_cli("'" + normal + "' --height -o '" + out + "'", "RELIEF_MEMORY_LIMIT=lots");
    CHECK(r.rc == 2);  // a usage error, before any work
    CHECK(r.err.find("RELIEF_MEMORY_LIMIT must be a size in bytes > 0") != std::string::npos);
    CHECK(r.err.find("not 'lots'") != std::string::npos);
}

TEST_CASE("io: image_size reads a header quietly, and fails quietly", "[io]")
{
    int w = 0, h = 0;
    const std::string dem = std::string(RELIEF_TEST_DATA) + "/dem_jacksboro/normal.png";  // 403 x 344
    REQUIRE(relief::image_size(dem, w, h));
    CHECK(w == 403);
    CHECK(h == 344);
    const auto dir = relief::test::scratch("io/image_size");
    {
        std::ofstream(dir / "damaged.png", std::ios::binary) << "\x89PNG\r\n\x1a\nnot really";
    }
    // A damaged file, a missing one, a FIFO (whose probe would hang): false,
    // no error left behind (the read reports it), nothing on stderr.
    const std::string fifo = (dir / "fifo.png").string();
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    ::alarm(30);  // a probe that hangs ends the process (SIGALRM), not the suite's patience
    for (const std::string& bad : {(dir / "damaged.png").string(), (dir / "missing.png").string(), fifo}) {
        INFO(bad);
        w = h = -1;
        CHECK_FALSE(relief::image_size(bad, w, h));
        CHECK(w == -1);
        CHECK(relief::geterror().empty());
    }
    ::alarm(0);
}
