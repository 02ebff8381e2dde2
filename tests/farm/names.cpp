// SPDX-License-Identifier: Apache-2.0
// <UDIM>, <UVTILE>, frame numbers and --frames: names that expand into
// jobs, as oiiotool and OpenImageIO name them.
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

TEST_CASE("names: <UDIM>, # @ %0Nd and --frames expand as oiiotool's", "[names][parse]")
{
    using V = std::vector<std::string>;
    using VV = std::vector<V>;
    using relief::cli::expand_names;
    const fs::path d = scratch("names");
    for (const char* t : {"1001", "1002", "1011"})
        std::ofstream(d / ("n." + std::string(t) + ".png")) << "x";
    const std::string in = (d / "n.<UDIM>.png").string();
    const auto tile = [&](const char* t) { return (d / ("n." + std::string(t) + ".png")).string(); };
    CHECK(expand_names({in, "--height", "-o", "h.<UDIM>.exr"}) ==
          VV{{tile("1001"), "--height", "-o", "h.1001.exr"},
             {tile("1002"), "--height", "-o", "h.1002.exr"},
             {tile("1011"), "--height", "-o", "h.1011.exr"}});
    // nothing to expand: the arguments as they are; # is literal without --frames
    CHECK(expand_names({"a#.png", "--height", "-o", "b@%04d.exr"}) ==
          VV{{"a#.png", "--height", "-o", "b@%04d.exr"}});
    CHECK(expand_names({"f.#.png", "--frames", "9-10,12", "-o", "o.%04d.exr"}) ==
          VV{{"f.0009.png", "-o", "o.0009.exr"},
             {"f.0010.png", "-o", "o.0010.exr"},
             {"f.0012.png", "-o", "o.0012.exr"}});
    CHECK(expand_names({"f.@@@.png", "--frames", "7", "-o", "o.%d.exr", "x.####.y%03dz##"}) ==
          VV{{"f.007.png", "-o", "o.7.exr", "x.0007.y007z07"}});
    CHECK(expand_names({"--frames", "1-2", in, "-o", "h.<UDIM>.#.exr"}).size() == 6);
    CHECK(expand_names({"--frames", "1-2", in, "-o", "h.<UDIM>.#.exr"})[4] ==
          V{tile("1002"), "-o", "h.1002.0002.exr"});
    // tiles and frames in one input name: each frame's own tiles
    for (const char* f : {"t.1001.0001.png", "t.1002.0001.png", "t.1001.0002.png"})
        std::ofstream(d / f) << "x";
    const std::string both = (d / "t.<UDIM>.#.png").string();
    CHECK(expand_names({both, "--frames", "1-3", "-o", "o.<UDIM>.#.exr"}) ==
          VV{{(d / "t.1001.0001.png").string(), "-o", "o.1001.0001.exr"},
             {(d / "t.1002.0001.png").string(), "-o", "o.1002.0001.exr"},
             {(d / "t.1001.0002.png").string(), "-o", "o.1001.0002.exr"},
             {(d / "t.<UDIM>.0003.png").string(), "-o", "o.<UDIM>.0003.exr"}});  // no tile: fails alone
    CHECK(expand_names({"a%%b%d.png", "--frames", "5"}) == VV{{"a%b5.png"}});
    // only the file-name part: folders keep their # and @; %# and %@ are a literal # and @
    CHECK(expand_names({"shots/#12/a@b/n.#.png", "--frames", "5"}) == VV{{"shots/#12/a@b/n.0005.png"}});
    CHECK(expand_names({"n.%#%@.@@.png", "--frames", "5"}) == VV{{"n.#@.05.png"}});
    // the manifest and the log are one file for the whole run: tokens there are refused
    CHECK_THROWS_WITH(expand_names({"--batch", "j#.txt", "--frames", "1-3"}),
                      Catch::Contains("--batch j#.txt: names one file for the whole run"));
    CHECK_THROWS_WITH(expand_names({in, "--slopes", "-o", "s.<UDIM>.exr", "--log", "l.<UDIM>.jsonl"}),
                      Catch::Contains("--log l.<UDIM>.jsonl: names one file"));
    CHECK(expand_names({"--batch", "j#.txt"}) == VV{{"--batch", "j#.txt"}});  // literal without --frames
    // the tiles are those of the first input holding <UDIM>, not of an output
    // (an earlier output with tiles of its own: o.1005.exr)
    std::ofstream(d / "o.1005.exr") << "x";
    CHECK(expand_names({"-o", (d / "o.<UDIM>.exr").string(), in}).size() == 3);
    for (const V& bad :
         {V{"x.<UDIM>.png"}, V{"a.png", "-o", "h.<UDIM>.exr"}, V{"a.png", "--frames", "1-3"},
          V{"a#.png", "--frames"}, V{"a#.png", "--frames", "3-1"}, V{"a#.png", "--frames", "1-"},
          V{"a#.png", "--frames", "1,,2"}, V{"a#.png", "--frames", "x"}, V{"a#.png", "--frames", "0-100000"},
          V{"a#.png", "--frames", "99999999999"}, V{"a#.png", "--frames", "5-99999999999"},
          V{"a#.png", "--frames", "2147483647"}, V{"a#.png", "--frames", "1", "--frames", "2"},
          V{"a%040d.png", "--frames", "1"}})
        CHECK_THROWS_AS(expand_names(bad), UsageError);
    // in a manifest, each line expands into jobs of its own; a line that cannot fails alone
    std::ofstream(d / "jobs.txt") << "'" << in
                                  << "' --slopes -o 'h.<UDIM>.exr'\nnone.<UDIM>.png --slopes -o x.exr\n"
                                  << tile("1001") << " --slopes -o y.exr\n";
    const std::vector<Job> jobs = relief::cli::read_jobs((d / "jobs.txt").string());
    REQUIRE(jobs.size() == 5);
    CHECK(jobs[2].args.back() == "h.1011.exr");
    CHECK(jobs[2].line == 1);
    CHECK(jobs[3].error.find("no UDIM tile") != std::string::npos);
    CHECK(jobs[3].line == 2);
    CHECK(jobs[4].index == 4);
    CHECK(jobs[4].error.empty());
}

TEST_CASE("names: <UVTILE>, <u> <v> <U> <V> and frame steps expand as OpenImageIO and oiiotool name them",
          "[names][parse]")
{
    using V = std::vector<std::string>;
    using VV = std::vector<V>;
    using relief::cli::expand_names;
    const fs::path d = scratch("uvtile");
    // u1_v1 is tile 1001, u2_v1 1002, u1_v2 1011; near misses: a leading
    // zero, u or v 0 (they count from 1), u past 10, no v, another suffix
    for (const char* f :
         {"n_u1_v1.png", "n_u2_v1.png", "n_u1_v2.png", "n_u01_v1.png", "n_u0_v1.png", "n_u1_v0.png",
          "n_u11_v1.png", "n_u3.png", "n_u4_v1.png.bak", "m_0_0.png", "m_1_0.png", "m_0_10.png", "k_1_1.png"})
        std::ofstream(d / f) << "x";
    const auto in = [&](const char* name) { return (d / name).string(); };
    CHECK(expand_names({in("n_<UVTILE>.png"), "-o", "o.<UDIM>.exr"}) ==
          VV{{in("n_u1_v1.png"), "-o", "o.1001.exr"},
             {in("n_u2_v1.png"), "-o", "o.1002.exr"},
             {in("n_u1_v2.png"), "-o", "o.1011.exr"}});
    // the same tile in every token kind
    CHECK(expand_names({in("m_<u>_<v>.png"), "-o", "o_<UVTILE>_<U>_<V>_<UDIM>.exr"}) ==
          VV{{in("m_0_0.png"), "-o", "o_u1_v1_1_1_1001.exr"},
             {in("m_1_0.png"), "-o", "o_u2_v1_2_1_1002.exr"},
             {in("m_0_10.png"), "-o", "o_u1_v11_1_11_1101.exr"}});
    CHECK(expand_names({in("k_<U>_<V>.png"), "-o", "o.<UDIM>.exr"}) ==
          VV{{in("k_1_1.png"), "-o", "o.1001.exr"}});
    // frames: x steps from the first, y takes the others (oiiotool)
    const auto frames = [&](const char* spec) {
        V outs;
        for (const V& job : expand_names({"f.#.png", "--frames", spec, "-o", "o.%d.exr"}))
            outs.push_back(job.back());
        return outs;
    };
    CHECK(frames("1-10x3") == V{"o.1.exr", "o.4.exr", "o.7.exr", "o.10.exr"});
    CHECK(frames("1-10y3") == V{"o.2.exr", "o.3.exr", "o.5.exr", "o.6.exr", "o.8.exr", "o.9.exr"});
    CHECK(frames("-4--1x2,7") == V{"o.-4.exr", "o.-2.exr", "o.7.exr"});
    CHECK(frames("5x2") == V{"o.5.exr"});
    CHECK(frames("1-3x1") == V{"o.1.exr", "o.2.exr", "o.3.exr"});  // a step of one is every frame
    // frame numbers up to 10^9 either way, and no further
    CHECK(frames("1000000000") == V{"o.1000000000.exr"});
    CHECK(frames("-1000000000") == V{"o.-1000000000.exr"});
    for (const char* bad : {"1-10x0", "1-10x", "1-10z2", "1-10x-2", "1-10xx2", "x2", "1-3y1", "1,",
                            "1000000001", "-1000000001"})
        CHECK_THROWS_AS(expand_names({"f.#.png", "--frames", bad}), UsageError);
    // %0Nd up to 32 digits; # in a folder's name is kept, in the file's replaced
    CHECK(expand_names({"a%032d.png", "--frames", "7"}) ==
          std::vector<V>{{"a" + std::string(31, '0') + "7.png"}});
    CHECK(expand_names({"o.%012d.exr", "--frames", "5"}) == std::vector<V>{{"o.000000000005.exr"}});
    CHECK_THROWS_WITH(expand_names({"a%033d.png", "--frames", "7"}),
                      Catch::Contains("a frame token of 33 digits (32 at most)"));
    CHECK(expand_names({"in#/#.png", "--frames", "5"}) == std::vector<V>{{"in#/0005.png"}});
}

TEST_CASE("names: an output that every tile or frame would write is refused before any job", "[names][parse]")
{
    using relief::cli::expand_names;
    const fs::path d = scratch("shared-outputs");
    for (const char* t : {"1001", "1002"})
        std::ofstream(d / ("n." + std::string(t) + ".png")) << "x";
    const std::string in = (d / "n.<UDIM>.png").string();
    CHECK_THROWS_WITH(expand_names({in, "--height", "-o", "h.exr"}),
                      "-o h.exr: 2 of this line's 2 tiles and frames would each write it; put the tile token "
                      "(<UDIM>, <UVTILE>) or a frame token (#, %04d) in the name");
    CHECK_THROWS_WITH(expand_names({in, "--height", "-o", "h.<UDIM>.exr", "--report", "r.json"}),
                      Catch::StartsWith("--report r.json: 2 of this line's 2 tiles"));
    CHECK_THROWS_WITH(expand_names({"f.#.png", "--frames", "1-2", "--height", "-o", "h.exr"}),
                      Catch::StartsWith("-o h.exr: 2 of this line's 2"));
    // tiles and frames: the frame token alone is not enough
    CHECK_THROWS_WITH(expand_names({in, "--frames", "1-2", "--height", "-o", "h.#.exr"}),
                      Catch::StartsWith("-o h.0001.exr: 2 of this line's 4"));
    CHECK(expand_names({in, "--frames", "1-2", "--height", "-o", "h.<UDIM>.#.exr"}).size() == 4);
    CHECK(expand_names({(d / "n.1001.png").string(), "--height", "-o", "h.exr"}).size() == 1);
    CHECK(expand_names({"f.#.png", "--frames", "3", "--height", "-o", "h.exr"}).size() == 1);
    // in a manifest the line fails alone, before any job runs
    std::ofstream(d / "jobs.txt") << "'" << in << "' --slopes -o h.exr\n"
                                  << "'" << in << "' --slopes -o 'h.<UDIM>.exr'\n";
    const auto jobs = relief::cli::read_jobs((d / "jobs.txt").string());
    REQUIRE(jobs.size() == 3);
    CHECK(jobs[0].error.find("would each write it") != std::string::npos);
    CHECK(jobs[1].error.empty());
    CHECK(jobs[2].args.back() == "h.1002.exr");
}

TEST_CASE("names: the tiles of <UDIM> are the files that exist, the token in a folder or twice in a name",
          "[names][parse][slow]")
{
    using V = std::vector<std::string>;
    using relief::cli::expand_names;
    const fs::path d = scratch("tiles");
    // near misses: five digits, out of range, not digits, another prefix
    for (const char* f : {"n.1001.png", "n.1999.png", "n.10010.png", "n.0999.png", "n.2000.png", "n.1a01.png",
                          "m.1002.png", "n.1003.png.bak", "n.1010.png"})
        std::ofstream(d / f) << "x";
    fs::create_directory(d / "n.1004.png");                // a folder is a name that exists, as before
    fs::create_symlink(d / "gone.png", d / "n.1005.png");  // a dangling link is not
    const auto tiles_of = [](const std::string& pattern) {
        V firsts;
        for (const V& job : expand_names({pattern, "-o", "o.<UDIM>.exr"}))
            firsts.push_back(job.back());
        return firsts;
    };
    // (1010: u = 10, the last column of the grid)
    CHECK(tiles_of((d / "n.<UDIM>.png").string()) ==
          V{"o.1001.exr", "o.1004.exr", "o.1010.exr", "o.1999.exr"});
    // the token twice: both the same tile
    std::ofstream(d / "a1002_b1002.png") << "x";
    std::ofstream(d / "a1002_b1003.png") << "x";
    CHECK(tiles_of((d / "a<UDIM>_b<UDIM>.png").string()) == V{"o.1002.exr"});
    // in a folder, and in the folder and the name
    // (1013/n1011.png: a name's tile that is not its folder's)
    for (const char* f : {"1011/n.png", "1012/n.png", "1012/n1012.png", "1013/x.png", "1013/n1011.png"}) {
        fs::create_directories((d / f).parent_path());
        std::ofstream(d / f) << "x";
    }
    std::ofstream(d / "1014") << "x";  // a file, not a folder
    CHECK(tiles_of((d / "<UDIM>/n.png").string()) == V{"o.1011.exr", "o.1012.exr"});
    CHECK(tiles_of((d / "<UDIM>/n<UDIM>.png").string()) == V{"o.1012.exr"});
    CHECK(tiles_of((d / "<UDIM>").string()) == V{"o.1011.exr", "o.1012.exr", "o.1013.exr", "o.1014.exr"});
    // a name without a folder is in the working folder
    const fs::path was = fs::current_path();
    fs::current_path(d);
    CHECK(tiles_of("n.<UDIM>.png") == V{"o.1001.exr", "o.1004.exr", "o.1010.exr", "o.1999.exr"});
    fs::current_path(was);
    // many frames and tiles: each folder is listed once, so this is quick
    V line = {"--frames", "1-20000", (d / "n.<UDIM>.png").string(), "-o", "o.<UDIM>.#.exr"};
    const auto jobs = expand_names(line);
    REQUIRE(jobs.size() == 80000);
    CHECK(jobs.back() == V{(d / "n.1999.png").string(), "-o", "o.1999.20000.exr"});
    // a line held once per frame may not grow past 64 MiB
    line.push_back(std::string(3000, 'x'));
    line[1] = "1-99999";
    CHECK_THROWS_WITH(expand_names(line), Catch::Contains("frames hold more than 64 MiB of arguments"));
}

TEST_CASE("names: a <UDIM> set and a # sequence run one job per existing tile and frame, each as its own run",
          "[names][cli][slow]")
{
    const fs::path d = scratch("tile-runs");
    write_crop(kNormal, d / "n.1001.png", 0);
    write_crop(kNormal, d / "n.1002.png", 96);
    write_crop(kDem, d / "n.1012.png", 0);
    fs::create_directories(d / "out");
    auto r = run_cli("'" + (d / "n.<UDIM>.png").string() + "' --height:udim=each -o '" +
                     (d / "out/h.<UDIM>.exr").string() + "'");
    INFO(r.err);
    CHECK(r.rc == 0);
    CHECK(r.err.find("3 ok, 0 skipped, 0 failed of 3 job(s)") != std::string::npos);
    std::set<std::string> made;
    for (const auto& e : fs::directory_iterator(d / "out"))
        made.insert(e.path().filename().string());
    CHECK(made == std::set<std::string>{"h.1001.exr", "h.1002.exr", "h.1012.exr"});
    for (const char* t : {"1001", "1012"}) {
        const fs::path single = d / ("single." + std::string(t) + ".exr");
        REQUIRE(run_cli("'" + (d / ("n." + std::string(t) + ".png")).string() + "' --height -o '" +
                        single.string() + "'")
                    .rc == 0);
        CHECK(relief::test::file_pixels(single) ==
              relief::test::file_pixels(d / "out" / ("h." + std::string(t) + ".exr")));
    }
    // frames 1001-1003: 1003 does not exist and fails alone
    auto f = run_cli("'" + (d / "n.#.png").string() + "' --frames 1001-1003 --slopes -o '" +
                     (d / "out/s.%04d.exr").string() + "'");
    CHECK(f.rc == 1);
    CHECK(f.err.find("job 2 (command line): error: cannot read '" + (d / "n.1003.png").string()) !=
          std::string::npos);
    CHECK(fs::exists(d / "out/s.1001.exr"));
    CHECK(fs::exists(d / "out/s.1002.exr"));
    CHECK_FALSE(fs::exists(d / "out/s.1003.exr"));
}

TEST_CASE("names: a <UDIM> set whose --height joins its tiles is one job, its digest over every tile",
          "[names][cli][udim]")
{
    const fs::path d = scratch("tile-set");
    // a 128x128 map and its four 64x64 tiles (v up: 1011, 1012 are the top half)
    OIIO::ImageBuf src(kNormal);
    OIIO::ImageBuf whole = OIIO::ImageBufAlgo::cut(src, OIIO::ROI(0, 128, 0, 128));
    whole.set_write_format(OIIO::TypeDesc::UINT8);
    REQUIRE(whole.write((d / "whole.png").string()));
    const std::map<std::string, OIIO::ROI> at = {{"1001", OIIO::ROI(0, 64, 64, 128)},
                                                 {"1002", OIIO::ROI(64, 128, 64, 128)},
                                                 {"1011", OIIO::ROI(0, 64, 0, 64)},
                                                 {"1012", OIIO::ROI(64, 128, 0, 64)}};
    for (const auto& [t, roi] : at) {
        OIIO::ImageBuf tile = OIIO::ImageBufAlgo::cut(whole, roi);
        tile.set_write_format(OIIO::TypeDesc::UINT8);
        REQUIRE(tile.write((d / ("n." + t + ".png")).string()));
    }
    auto run = [&](const std::string& args) {
        fs::remove(d / "log.jsonl");
        return run_cli(args, "cd '" + d.string() + "' &&");
    };
    const std::string line = "n.\\<UDIM\\>.png --height:udim=joint:boundary=periodic -o h.\\<UDIM\\>.exr";
    auto r = run(line + " --update --log log.jsonl");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("1 ok, 0 skipped, 0 failed of 1 job(s)") != std::string::npos);
    const std::vector<std::string> log = lines_of(d / "log.jsonl");
    REQUIRE(log.size() == 1);
    CHECK(log[0].find("\"inputs\":[\"n.1001.png\",\"n.1002.png\",\"n.1011.png\",\"n.1012.png\"]") !=
          std::string::npos);
    CHECK(log[0].find("\"args\":[\"n.<UDIM>.png\"") != std::string::npos);
    // each tile: the whole map's solve, cut
    REQUIRE(run("whole.png --height:boundary=periodic -o whole.exr").rc == 0);
    OIIO::ImageBuf expected((d / "whole.exr").string());
    for (const auto& [t, roi] : at) {
        INFO("tile " << t);
        CHECK(relief::test::file_pixels(d / ("h." + t + ".exr")) ==
              relief::test::pixels(OIIO::ImageBufAlgo::cut(expected, roi)));
    }
    // up to date until any tile changes; then every tile's output is stale
    CHECK(run(line + " --update").err.find("0 ok, 1 skipped") != std::string::npos);
    const std::string before = relief::recorded_digest((d / "h.1001.exr").string());
    {
        OIIO::ImageBuf other = OIIO::ImageBufAlgo::cut(src, OIIO::ROI(300, 364, 300, 364));
        other.set_write_format(OIIO::TypeDesc::UINT8);
        REQUIRE(other.write((d / "n.1012.png").string()));
    }
    CHECK(run(line + " --update --dry-run").out.find("\"status\":\"pending\"") != std::string::npos);
    CHECK(run(line + " --update").err.find("1 ok, 0 skipped") != std::string::npos);
    CHECK(relief::recorded_digest((d / "h.1001.exr").string()) != before);
    // udim=each: one job per tile, as before
    CHECK(run("n.\\<UDIM\\>.png --height:udim=each -o e.\\<UDIM\\>.exr")
              .err.find("4 ok, 0 skipped, 0 failed of 4") != std::string::npos);
    // in a manifest the set is one job, and a shard runs all of it or none
    const std::string q = "'" + d.string() + "/";
    std::ofstream(d / "jobs.txt") << q << "n.<UDIM>.png' --height:udim=joint -o " << q << "b.<UDIM>.exr'\n"
                                  << q << "whole.png' --slopes -o " << q << "s.exr'\n";
    const std::vector<Job> jobs = relief::cli::read_jobs((d / "jobs.txt").string());
    REQUIRE(jobs.size() == 2);
    REQUIRE(jobs[0].tiles == std::vector<int>{1001, 1002, 1011, 1012});
    CHECK(jobs[0].tile_args[3].back() == (d / "b.1012.exr").string());
    CHECK(jobs[1].index == 1);
    // two tiles are a set too; one tile is a plain job, named
    for (const auto& [folder, tiles] :
         {std::pair{"two", std::vector<int>{1001, 1002}}, std::pair{"one", std::vector<int>{1001}}}) {
        fs::create_directories(d / folder);
        for (const int t : tiles)
            fs::copy_file(d / ("n." + std::to_string(t) + ".png"),
                          d / folder / ("n." + std::to_string(t) + ".png"),
                          fs::copy_options::overwrite_existing);
        std::ofstream(d / folder / "jobs.txt")
            << q << folder << "/n.<UDIM>.png' --height:udim=joint -o " << q << folder << "/b.<UDIM>.exr'\n";
        const std::vector<Job> set = relief::cli::read_jobs((d / folder / "jobs.txt").string());
        INFO(folder);
        REQUIRE(set.size() == 1);
        CHECK(set[0].tiles == (tiles.size() > 1 ? tiles : std::vector<int>{}));
        if (tiles.size() == 1)
            CHECK(set[0].args.front() == (d / folder / "n.1001.png").string());
    }
    auto shard = run("--batch jobs.txt --shard 0/2");
    INFO(shard.err);
    CHECK(shard.rc == 0);
    for (const char* t : {"1001", "1002", "1011", "1012"})
        CHECK(fs::exists(d / ("b." + std::string(t) + ".exr")));
    CHECK_FALSE(fs::exists(d / "s.exr"));
    // an output name without the token would be written once per tile
    auto clash = run("n.\\<UDIM\\>.png --height:udim=joint -o one.exr");
    CHECK(clash.rc != 0);
    CHECK_FALSE(fs::exists(d / "one.exr"));
}
