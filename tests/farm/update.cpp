// SPDX-License-Identifier: Apache-2.0
// --update: a job is skipped exactly when its outputs record the digest it
// would write.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include <unistd.h>

#include "batch.h"
#include "json_text.h"
#include "command_line.h"
#include "relief/imageio.h"
#include "support/images.h"
#include "support/run_cli.h"
#include "farm/farm_test.h"

using namespace relief::test::farm;

TEST_CASE("update: a job is skipped exactly when its outputs record the digest it would write",
          "[update][cli][slow]")
{
    const fs::path d = scratch("update");
    for (int i = 0; i < 4; ++i)
        write_crop(i % 2 ? kDem : kNormal, d / ("n" + std::to_string(i) + ".png"), 8 * i);
    const fs::path m = d / "jobs.txt";
    const auto manifest = [&](const std::string& job1_modifiers, const std::string& job2_type,
                              const std::string& job1_outputs = "-o h1.exr -o h1.png") {
        std::ofstream f(m);
        f << "n0.png --height -o h0.exr\n";
        f << "n1.png --height" << job1_modifiers << " " << job1_outputs << "\n";
        f << "n2.png --slopes -d " << job2_type << " -o s2.exr\n";
        f << "n3.png --height -o h3.tif\n";  // TIFF keeps the digest in ImageDescription
    };
    manifest("", "float");
    const fs::path log = d / "log.jsonl";
    auto run = [&](const std::string& extra = "", const std::string& env = "") {
        fs::remove(log);  // --log appends: each run's lines alone
        return relief::test::run_cli("--batch jobs.txt --update --log log.jsonl " + extra,
                                     env + " cd '" + d.string() + "' &&");
    };
    using S = std::vector<std::string>;
    auto r = run();
    INFO(r.err);
    REQUIRE(r.rc == 0);
    CHECK(statuses(log) == S{"ok", "ok", "ok", "ok"});
    const std::string digest = relief::recorded_digest((d / "h0.exr").string());
    CHECK(digest.size() == 32);
    // each output records its own place in the job
    CHECK(relief::recorded_digest((d / "h1.png").string()).size() == 32);
    CHECK(relief::recorded_digest((d / "h1.png").string()) !=
          relief::recorded_digest((d / "h1.exr").string()));
    CHECK(relief::recorded_digest((d / "h3.tif").string()).size() == 32);
    CHECK(relief::recorded_digest((d / "n0.png").string()).empty());
    const auto h0_time = fs::last_write_time(d / "h0.exr");

    // nothing changed: everything skipped, nothing rewritten
    r = run();
    CHECK(r.rc == 0);
    CHECK(statuses(log) == S{"skipped", "skipped", "skipped", "skipped"});
    CHECK(fields(log, "message") == S{"up to date", "up to date", "up to date", "up to date"});
    CHECK(r.err.find("0 ok, 4 skipped, 0 failed of 4 job(s)") != std::string::npos);
    CHECK(fs::last_write_time(d / "h0.exr") == h0_time);
    // the same bytes written again (a new mtime) are the same input
    fs::copy_file(d / "n3.png", d / "n3.copy.png");
    fs::remove(d / "n3.png");
    fs::rename(d / "n3.copy.png", d / "n3.png");
    CHECK(statuses((run(), log)) == S{"skipped", "skipped", "skipped", "skipped"});

    // a changed input byte, a changed modifier, a changed -d: exactly those run
    write_crop(kNormal, d / "n0.png", 40);
    manifest(":normal=opengl", "half");
    auto dry = relief::test::run_cli("--batch jobs.txt --update --dry-run", "cd '" + d.string() + "' &&");
    CHECK(dry.rc == 0);
    CHECK(dry.out.find("\"status\":\"pending\"") != std::string::npos);
    CHECK(dry.err.find("3 pending, 1 skipped, 0 failed of 4 job(s) (dry run)") != std::string::npos);
    CHECK(fs::last_write_time(d / "h0.exr") == h0_time);  // a dry run writes nothing
    r = run();
    CHECK(statuses(log) == S{"ok", "ok", "ok", "skipped"});
    CHECK(relief::recorded_digest((d / "h0.exr").string()) != digest);
    fs::remove(d / "h1.png");  // one of a job's two outputs lost
    CHECK(statuses((run(), log)) == S{"skipped", "ok", "skipped", "skipped"});
    manifest(":normal=opengl", "half", "-o h1.png -o h1.exr");  // the outputs' names swapped
    CHECK(statuses((run(), log)) == S{"skipped", "ok", "skipped", "skipped"});
    CHECK(statuses((run(), log)) == S{"skipped", "skipped", "skipped", "skipped"});
    // without --update every job runs
    fs::remove(log);
    CHECK(statuses((relief::test::run_cli("--batch jobs.txt --log log.jsonl", "cd '" + d.string() + "' &&"),
                    log)) == S{"ok", "ok", "ok", "ok"});

    // other kernels (RELIEF_KERNEL_DIR) are another implementation: every job is pending
    const fs::path kernels = d / "kernels";
    fs::copy(RELIEF_KERNELS_DIR, kernels);
    dry = relief::test::run_cli("--batch jobs.txt --update --dry-run",
                                "cd '" + d.string() + "' && RELIEF_KERNEL_DIR='" + kernels.string() + "'");
    CHECK(dry.err.find("0 pending, 4 skipped") != std::string::npos);  // the same sources
    std::ofstream(kernels / "ddm.cl", std::ios::app) << "\n// changed\n";
    dry = relief::test::run_cli("--batch jobs.txt --update --dry-run",
                                "cd '" + d.string() + "' && RELIEF_KERNEL_DIR='" + kernels.string() + "'");
    CHECK(dry.err.find("4 pending, 0 skipped") != std::string::npos);

    // a digest belongs to its file: reading an output does not carry it into another
    OIIO::ImageBuf img;
    for (const char* out : {"h0.exr", "h3.tif"}) {
        REQUIRE(relief::read_image(img, (d / out).string()));
        CHECK(img.spec().get_string_attribute("relief:digest").empty());
        CHECK(img.spec().get_string_attribute("ImageDescription").find("relief:digest") == std::string::npos);
        REQUIRE(relief::write_image(img, (d / "copy.exr").string()));
        CHECK(relief::recorded_digest((d / "copy.exr").string()).empty());
    }

    // paths do not count: an input and a mask moved (same bytes) keep the jobs up to date
    {
        std::ofstream f(m);
        f << "n0.png --height:mask=n1.png -o hm.exr\n";
    }
    CHECK(statuses((run(), log)) == S{"ok"});
    fs::rename(d / "n0.png", d / "moved0.png");
    fs::rename(d / "n1.png", d / "moved1.png");
    {
        std::ofstream f(m);
        f << "moved0.png --height:mask=moved1.png -o hm.exr\n";
    }
    CHECK(statuses((run(), log)) == S{"skipped"});
    write_crop(kDem, d / "moved1.png", 24);  // the mask's bytes do count
    CHECK(statuses((run(), log)) == S{"ok"});
}

TEST_CASE("update: a single run up to date says so under -v only, and writes nothing", "[update][cli]")
{
    const fs::path d = scratch("update_single");
    write_crop(kNormal, d / "n.png", 0);
    const std::string args = "n.png --height -o h.exr --update";
    const std::string in_d = "cd '" + d.string() + "' &&";
    auto r = relief::test::run_cli(args + " -v", in_d);
    INFO(r.err);
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("up to date") == std::string::npos);
    const auto written = fs::last_write_time(d / "h.exr");
    r = relief::test::run_cli(args + " -v --log log.jsonl", in_d);
    INFO(r.err);
    CHECK(r.rc == 0);
    CHECK(r.err.find("relief: up to date (every output records this run's relief:digest)\n") !=
          std::string::npos);
    CHECK(r.err.find("--height:") == std::string::npos);  // no step ran
    CHECK(statuses(d / "log.jsonl") == std::vector<std::string>{"skipped"});
    r = relief::test::run_cli(args, in_d);
    CHECK(r.rc == 0);
    CHECK(r.err.empty());
    CHECK(fs::last_write_time(d / "h.exr") == written);
    // Another compression is another output: it runs, then is up to date.
    const std::string zip = "n.png --height --compression zip -o h.exr --update -v";
    r = relief::test::run_cli(zip, in_d);
    CHECK(r.rc == 0);
    CHECK(r.err.find("up to date") == std::string::npos);
    CHECK(relief::test::run_cli(zip, in_d).err.find("relief: up to date") != std::string::npos);
    // A map one texel wide carries its pixel digest as any other does.
    {
        OIIO::ImageBuf src(kNormal);
        OIIO::ImageBuf column = OIIO::ImageBufAlgo::cut(src, OIIO::ROI(0, 1, 0, 32));
        column.set_write_format(OIIO::TypeDesc::UINT8);
        REQUIRE(column.write((d / "column.png").string()));
    }
    const std::string thin = "column.png --height -o column.exr --update -v";
    REQUIRE(relief::test::run_cli(thin, in_d).rc == 0);
    r = relief::test::run_cli(thin, in_d);
    INFO(r.err);
    CHECK(r.err.find("relief: up to date") != std::string::npos);
}

TEST_CASE("update: a dry run calls a chain's reader pending when the job it reads would run, as the real run "
          "does",
          "[update][cli]")
{
    const fs::path d = scratch("update_chain");
    write_crop(kNormal, d / "n.png", 0, 64);
    const auto manifest = [&](const std::string& modifiers) {
        std::ofstream f(d / "jobs.txt");
        f << "n.png --height" << modifiers << " -o a.exr\na.exr --normals -o b.exr\n"
          << "b.exr --slopes -o c.exr\n";  // (a third link: pending because its reader's writer is)
    };
    const auto run = [&](const std::string& extra) {
        fs::remove(d / "log.jsonl");
        return relief::test::run_cli("--batch jobs.txt --update --log log.jsonl " + extra,
                                     "cd '" + d.string() + "' &&");
    };
    using S = std::vector<std::string>;
    manifest("");
    REQUIRE(run("").rc == 0);
    CHECK(statuses(d / "log.jsonl") == S{"ok", "ok", "ok"});
    auto dry = run("--dry-run");
    CHECK(dry.err.find("0 pending, 3 skipped") != std::string::npos);
    manifest(":boundary=free");  // the writer changes; its reader's file on disk does not, yet
    dry = run("--dry-run");
    INFO(dry.out);
    CHECK(dry.err.find("3 pending, 0 skipped") != std::string::npos);
    CHECK(dry.out.find("reads the output of job 0, which would run") != std::string::npos);
    CHECK(dry.out.find("reads the output of job 1, which would run") != std::string::npos);
    CHECK(run("").rc == 0);
    CHECK(statuses(d / "log.jsonl") == S{"ok", "ok", "ok"});
}
