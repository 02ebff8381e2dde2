// SPDX-License-Identifier: Apache-2.0
// --batch, --shard and --log: manifests of ordinary command lines run in
// one process, a failed job alone failing, shards covering every job once.
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

namespace fs = std::filesystem;
using relief::cli::Job;
using relief::cli::UsageError;
using relief::test::run_cli;

namespace {

const std::string kData = std::string(RELIEF_TEST_DATA);
const std::string kNormal = kData + "/gk_metal_tech_01/normal.png";
const std::string kDem = kData + "/dem_jacksboro/normal.png";

fs::path scratch(const std::string& name)
{
    fs::path d = fs::path(RELIEF_TEST_TMP) / "batch" / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

std::vector<std::string> lines_of(const fs::path& p)
{
    std::ifstream in(p);
    std::vector<std::string> v;
    for (std::string l; std::getline(in, l);)
        v.push_back(l);
    return v;
}

}  // namespace

TEST_CASE("batch: manifest lines split like a shell, without expansion", "[batch][parse]")
{
    using V = std::vector<std::string>;
    CHECK(relief::cli::split_words("a b\tc") == V{"a", "b", "c"});
    CHECK(relief::cli::split_words("  ") == V{});
    CHECK(relief::cli::split_words("# a comment") == V{});
    CHECK(relief::cli::split_words("in.png --height # trailing") == V{"in.png", "--height"});
    CHECK(relief::cli::split_words("a#b") == V{"a#b"});
    CHECK(relief::cli::split_words("'my map.png' -o \"out dir/h.exr\"") ==
          V{"my map.png", "-o", "out dir/h.exr"});
    CHECK(relief::cli::split_words("'$HOME/*.png'") == V{"$HOME/*.png"});
    CHECK(relief::cli::split_words("$HOME *.png ~") == V{"$HOME", "*.png", "~"});
    CHECK(relief::cli::split_words(R"("a \"q\" \\ \$x \n")") == V{R"(a "q" \ $x \n)"});
    CHECK(relief::cli::split_words(R"(a\ b c\'d)") == V{"a b", "c'd"});
    CHECK(relief::cli::split_words("''") == V{""});
    CHECK(relief::cli::split_words("x'y'\"z\"") == V{"xyz"});
    CHECK_THROWS_AS(relief::cli::split_words("'open"), UsageError);
    CHECK_THROWS_AS(relief::cli::split_words("\"open"), UsageError);
    CHECK_THROWS_AS(relief::cli::split_words("tail\\"), UsageError);
    // a NUL would cut the name short at open(): refused, quoted or not
    CHECK_THROWS_AS(relief::cli::split_words(std::string("in.png -o nul.exr\0.png", 22)), UsageError);
    CHECK_THROWS_AS(relief::cli::split_words(std::string("-o 'a\0b'", 8)), UsageError);
}

TEST_CASE("batch: shards take the jobs congruent to I mod N, every job exactly once", "[batch][parse]")
{
    std::vector<Job> jobs(7);
    for (int i = 0; i < 7; ++i)
        jobs[i].index = i;
    for (int n = 1; n <= 8; ++n) {
        std::multiset<int> seen;
        for (int i = 0; i < n; ++i)
            for (const Job& j : relief::cli::shard_of(jobs, i, n)) {
                CHECK(j.index % n == i);
                seen.insert(j.index);
            }
        CHECK(seen == std::multiset<int>{0, 1, 2, 3, 4, 5, 6});
    }
    CHECK(relief::cli::parse_shard("2/3") == std::pair<int, int>{2, 3});
    CHECK(relief::cli::parse_shard("0/1") == std::pair<int, int>{0, 1});
    for (const char* bad : {"3/3", "-1/3", "1/0", "1", "/3", "1/", "a/b", "1/3x"})
        CHECK_THROWS_AS(relief::cli::parse_shard(bad), UsageError);

    const fs::path d = scratch("parse");
    const fs::path m = d / "jobs.txt";
    std::ofstream(m) << "# header\n\n"
                     << kNormal << " --height -o a.exr\n  \n'" << kNormal << "' --slopes -o 'b c.exr'\n";
    const std::vector<Job> read = relief::cli::read_jobs(m.string());
    REQUIRE(read.size() == 2);
    CHECK(read[0].index == 0);
    CHECK(read[0].line == 3);
    CHECK(read[1].index == 1);
    CHECK(read[1].line == 5);
    CHECK(read[1].args.back() == "b c.exr");
    std::ofstream(d / "broken.txt") << "ok\nin.png -o 'x\n";
    try {
        relief::cli::read_jobs((d / "broken.txt").string());
        FAIL("accepted");
    } catch (const UsageError& e) {
        CHECK(std::string(e.what()).find("broken.txt:2: unterminated ' quote") != std::string::npos);
    }
    using relief::cli::parse_command_line;
    CHECK(parse_command_line({"--batch", m.string(), "--shard", "1/4"}).shard_count == 4);
    CHECK(parse_command_line({"--batch", m.string(), "--shard", "1/4"}).shard_index == 1);
    CHECK_THROWS_AS(parse_command_line({"--batch", m.string(), kNormal, "--height"}), UsageError);
    CHECK_THROWS_AS(parse_command_line({kNormal, "--height", "--shard", "0/2"}), UsageError);
    CHECK_THROWS_AS(parse_command_line({"--batch", (d / "none.txt").string()}), UsageError);
    CHECK_THROWS_AS(parse_command_line({"--batch", m.string(), "--log", (d / "no" / "l.jsonl").string()}),
                    UsageError);
}

TEST_CASE("batch: jobs run in one process, a failed job alone fails, the log says what each did",
          "[batch][cli]")
{
    const fs::path d = scratch("run");
    const fs::path m = d / "jobs.txt";
    {
        std::ofstream f(m);
        f << "# two maps, a missing input, a bad modifier, a third map\n";
        f << "'" << kNormal << "' --height:normal=opengl -o '" << (d / "h 0.exr").string() << "'\n";
        f << kDem << " --height:rays=8:radius=16 -o " << (d / "h1.exr").string() << "\n";
        f << (d / "missing.png").string() << " --height -o " << (d / "h2.exr").string() << "\n";
        f << kDem << " --height:rays=-3 -o " << (d / "h3.exr").string() << "\n";
        f << kDem << " --slopes:normal=directx -o " << (d / "s4.exr").string() << "\n";
    }
    const fs::path log = d / "log.jsonl";
    const auto started = std::chrono::steady_clock::now();
    auto r = run_cli("--device auto --batch '" + m.string() + "' --log '" + log.string() + "'");
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    INFO(r.err);
    CHECK(r.rc == 1);
    CHECK(r.err.find("job 2 (" + m.string() + ":4): error: cannot read") != std::string::npos);
    CHECK(r.err.find("job 3 (" + m.string() + ":5): error: --height:rays=-3: rays=-3 must be") !=
          std::string::npos);
    CHECK(r.err.find("relief: job 0: boundary:") != std::string::npos);  // messages name their job
    CHECK(r.err.find("3 ok, 0 skipped, 2 failed of 5 job(s)") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "h2.exr"));
    CHECK_FALSE(fs::exists(d / "h3.exr"));

    // each output equals the same job run on its own
    const std::pair<std::string, std::string> singles[] = {
        {"'" + kNormal + "' --height:normal=opengl", "h 0.exr"},
        {kDem + " --height:rays=8:radius=16", "h1.exr"},
        {kDem + " --slopes:normal=directx", "s4.exr"},
    };
    for (const auto& [args, name] : singles) {
        INFO(name);
        const fs::path single = d / ("single-" + name);
        REQUIRE(run_cli(args + " -o '" + single.string() + "'").rc == 0);
        CHECK(relief::test::file_pixels(d / name) == relief::test::file_pixels(single));
    }

    const std::vector<std::string> lines = lines_of(log);
    REQUIRE(lines.size() == 5);
    CHECK(lines[0].rfind("{\"job\":0,\"line\":2,\"args\":[\"" + kNormal +
                             "\",\"--height:normal=opengl\",\"-o\",\"" + (d / "h 0.exr").string() +
                             "\"],\"inputs\":[\"" + kNormal + "\"],\"outputs\":[\"" +
                             (d / "h 0.exr").string() + "\"],\"status\":\"ok\",\"seconds\":",
                         0) == 0);
    CHECK(lines[2].find("\"job\":2,\"line\":4,") != std::string::npos);
    CHECK(lines[2].find("\"status\":\"failed\"") != std::string::npos);
    CHECK(lines[2].find("\"message\":\"cannot read") != std::string::npos);
    CHECK(lines[3].find("\"status\":\"failed\"") != std::string::npos);
    CHECK(lines[4].find("\"status\":\"ok\"") != std::string::npos);
    CHECK(lines[4].find("\"message\":\"\",\"time\":") != std::string::npos);
    // Every record has every field, in order, each of its JSON type; the
    // times are each job's own, in seconds, and add up to at most the batch's.
    double total = 0.0;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        INFO(lines[i]);
        const auto r = nlohmann::ordered_json::parse(lines[i]);
        std::vector<std::string> keys;
        for (const auto& item : r.items())
            keys.push_back(item.key());
        CHECK(keys == std::vector<std::string>{"job", "line", "args", "inputs", "outputs", "status",
                                               "seconds", "message", "time", "host"});
        // when it ended, in UTC, and where
        CHECK(std::regex_match(r["time"].get<std::string>(),
                               std::regex(R"(20\d\d-[01]\d-[0-3]\dT[0-2]\d:[0-5]\d:[0-6]\dZ)")));
        char host[256] = {};
        gethostname(host, sizeof host - 1);
        CHECK(r["host"] == std::string(host));
        CHECK(r["job"] == int(i));
        CHECK(r["line"] == int(i) + 2);  // the manifest's line, after its comment
        CHECK(r["args"].is_array());
        CHECK(r["inputs"].is_array());
        CHECK(r["outputs"].is_array());
        CHECK(r["status"] == (i == 2 || i == 3 ? "failed" : "ok"));
        REQUIRE(r["seconds"].is_number());
        const double seconds = r["seconds"];
        CHECK(seconds * 1000.0 == Approx(std::round(seconds * 1000.0)));  // to the millisecond
        CHECK(r["message"].get<std::string>().empty() == (r["status"] == "ok"));
        total += seconds;
    }
    CHECK(total > 0.0);
    CHECK(total <= wall);
    CHECK(lines[1].find("\"inputs\":[\"" + kDem + "\"],\"outputs\":[\"" + (d / "h1.exr").string() + "\"]") !=
          std::string::npos);

    // all jobs fine: exit 0
    std::ofstream(d / "good.txt") << kDem << " --slopes -o " << (d / "g.exr").string() << "\n";
    CHECK(run_cli("--batch '" + (d / "good.txt").string() + "'").rc == 0);
    // the batch's --device reaches every job (a job's own would come after it and win)
    auto nodev = run_cli("--device 9:9 --batch '" + (d / "good.txt").string() + "'");
    CHECK(nodev.rc == 1);
    CHECK(nodev.err.find("job 0 (") != std::string::npos);
    CHECK(nodev.err.find("no OpenCL device 9:9") != std::string::npos);
    std::ofstream(d / "own.txt") << "--device cpu " << kDem << " --slopes -o " << (d / "g2.exr").string()
                                 << "\n";
    CHECK(run_cli("--device 9:9 --batch '" + (d / "own.txt").string() + "'").rc == 0);
    // the manifest's own syntax is a usage error before any job
    std::ofstream(d / "bad.txt") << kDem << " --slopes -o " << (d / "never.exr").string() << "\n'open\n";
    auto b = run_cli("--batch '" + (d / "bad.txt").string() + "'");
    CHECK(b.rc == 2);
    CHECK(b.err.find("bad.txt:2: unterminated ' quote") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "never.exr"));
}

TEST_CASE("batch: three shards of six jobs cover each job exactly once", "[batch][cli]")
{
    const fs::path d = scratch("shards");
    const fs::path m = d / "jobs.txt";
    {
        std::ofstream f(m);
        for (int i = 0; i < 6; ++i)
            f << kDem << " --slopes -o " << (d / ("s" + std::to_string(i) + ".exr")).string() << "\n";
    }
    std::multiset<int> done;
    for (int s = 0; s < 3; ++s) {
        const fs::path log = d / ("shard" + std::to_string(s) + ".jsonl");
        auto r = run_cli("--batch '" + m.string() + "' --shard " + std::to_string(s) + "/3 --log '" +
                         log.string() + "'");
        INFO(r.err);
        REQUIRE(r.rc == 0);
        CHECK(r.err.find("2 ok, 0 skipped, 0 failed of 2 job(s) (shard " + std::to_string(s) + "/3 of 6)") !=
              std::string::npos);
        for (const std::string& l : lines_of(log)) {
            const int job = std::stoi(l.substr(std::string("{\"job\":").size()));
            CHECK(job % 3 == s);
            done.insert(job);
        }
    }
    CHECK(done == std::multiset<int>{0, 1, 2, 3, 4, 5});
    for (int i = 0; i < 6; ++i)
        CHECK(fs::exists(d / ("s" + std::to_string(i) + ".exr")));
}

namespace {

// A small 8-bit PNG crop of a bundled normal map, for quick jobs.
void write_crop(const std::string& from, const fs::path& to, int x0, int size = 96)
{
    OIIO::ImageBuf src(from);
    OIIO::ImageBuf crop = OIIO::ImageBufAlgo::cut(src, OIIO::ROI(x0, x0 + size, 0, size));
    crop.set_write_format(OIIO::TypeDesc::UINT8);
    REQUIRE(crop.write(to.string()));
}

std::vector<std::string> statuses(const fs::path& log)
{
    std::vector<std::string> s;
    for (const std::string& l : lines_of(log)) {
        const std::size_t at = l.find("\"status\":\"") + 10;
        s.push_back(l.substr(at, l.find('"', at) - at));
    }
    return s;
}

}  // namespace

TEST_CASE("batch: jobs overlap (reads ahead, writes behind), yet each job's lines, record and failure "
          "stay its own",
          "[batch][cli]")
{
    const fs::path d = scratch("overlap");
    // A damaged file (job 1, read ahead while job 0 computes) and a write
    // that fails (job 2's 2 MiB of uncompressed slopes under a 1.5 MiB file
    // size limit, written behind while job 3 computes); job 4 reads job 3's
    // output, so it must wait for that write, and not be read ahead.
    {
        std::ifstream in(kNormal, std::ios::binary);
        std::string bytes(3000, '\0');
        in.read(bytes.data(), std::streamsize(bytes.size()));
        std::ofstream(d / "damaged.png", std::ios::binary) << bytes;
    }
    const fs::path m = d / "jobs.txt";
    {
        std::ofstream f(m);
        f << kNormal << " --height -o " << (d / "a.exr").string() << "\n";
        f << (d / "damaged.png").string() << " --height -o " << (d / "b.exr").string() << "\n";
        f << kNormal << " --slopes -o " << (d / "c.exr").string() << "\n";
        f << kDem << " --slopes -o " << (d / "e.exr").string() << "\n";
        f << (d / "e.exr").string() << " --height -o " << (d / "g.exr").string() << "\n";
    }
    // A stale e.exr from an earlier run: job 4 must read the one job 3 writes.
    REQUIRE(run_cli(kNormal + " --slopes -o " + (d / "e.exr").string()).rc == 0);
    const std::string limit = "trap '' XFSZ; prlimit --fsize=1572864";
    const fs::path log = d / "log.jsonl";
    auto r = run_cli("-v --batch '" + m.string() + "' --log '" + log.string() + "'", limit);
    INFO(r.err);
    CHECK(r.rc == 1);
    CHECK(statuses(log) == std::vector<std::string>{"ok", "failed", "failed", "ok", "ok"});
    CHECK(r.err.find("3 ok, 0 skipped, 2 failed of 5 job(s)") != std::string::npos);
    // The failures say what the same job says on its own.
    for (const auto& [job, args] :
         {std::pair{1, (d / "damaged.png").string() + " --height -o " + (d / "b1.exr").string()},
          std::pair{2, kNormal + " --slopes -o " + (d / "c.exr").string()}}) {
        const auto single = run_cli(args, limit);
        CHECK(single.rc == 1);
        const std::string why = single.err.substr(single.err.find("relief: error: ") + 8);
        CHECK(r.err.find("relief: job " + std::to_string(job) + " (" + m.string() + ":" +
                         std::to_string(job + 1) + "): " + why) != std::string::npos);
    }
    CHECK_FALSE(fs::exists(d / "b.exr"));
    CHECK_FALSE(fs::exists(d / "c.exr"));
    for (const auto& f : fs::directory_iterator(d))  // no temporary left behind
        CHECK(f.path().filename().string().find(".tmp") == std::string::npos);
    // Each job's lines come together and in job order, its last the
    // status line that ends it.
    int last = -1;
    std::istringstream lines(r.err);
    for (std::string l; std::getline(lines, l);) {
        int job = -1;
        if (std::sscanf(l.c_str(), "relief: job %d", &job) != 1)
            continue;
        INFO(l);
        CHECK(job >= last);
        last = job;
    }
    CHECK(last == 4);
    // -v says how much file work went beside the device's: some of each.
    double ahead = 0, behind = 0;
    const std::size_t at = r.err.find("relief: overlap: ");
    REQUIRE(at != std::string::npos);
    REQUIRE(std::sscanf(r.err.c_str() + at,
                        "relief: overlap: %lf s of reading ahead and %lf s of writing behind", &ahead,
                        &behind) == 2);
    CHECK(ahead > 0.0);
    CHECK(behind > 0.0);
    // Every output equals its single run, the chained one included.
    for (const auto& [args, name] :
         {std::pair{kNormal + " --height", "a.exr"}, std::pair{kDem + " --slopes", "e.exr"},
          std::pair{(d / "e.exr").string() + " --height", "g.exr"}}) {
        INFO(name);
        const fs::path single = d / ("single-" + std::string(name));
        REQUIRE(run_cli(args + " -o '" + single.string() + "'").rc == 0);
        CHECK(relief::test::file_pixels(d / name) == relief::test::file_pixels(single));
    }
}

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
    // zero, u past 10, no v, another suffix
    for (const char* f : {"n_u1_v1.png", "n_u2_v1.png", "n_u1_v2.png", "n_u01_v1.png", "n_u11_v1.png",
                          "n_u3.png", "n_u4_v1.png.bak", "m_0_0.png", "m_1_0.png", "m_0_10.png", "k_1_1.png"})
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
    for (const char* bad : {"1-10x0", "1-10x", "1-10z2", "1-10x-2", "1-10xx2", "x2", "1-3y1"})
        CHECK_THROWS_AS(expand_names({"f.#.png", "--frames", bad}), UsageError);
}

TEST_CASE("names: an output that every tile or frame would write is refused before any job", "[names][parse]")
{
    using V = std::vector<std::string>;
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
          "[names][parse]")
{
    using V = std::vector<std::string>;
    using relief::cli::expand_names;
    const fs::path d = scratch("tiles");
    // near misses: five digits, out of range, not digits, another prefix
    for (const char* f : {"n.1001.png", "n.1999.png", "n.10010.png", "n.0999.png", "n.2000.png", "n.1a01.png",
                          "m.1002.png", "n.1003.png.bak"})
        std::ofstream(d / f) << "x";
    fs::create_directory(d / "n.1004.png");                // a folder is a name that exists, as before
    fs::create_symlink(d / "gone.png", d / "n.1005.png");  // a dangling link is not
    const auto tiles_of = [](const std::string& pattern) {
        V firsts;
        for (const V& job : expand_names({pattern, "-o", "o.<UDIM>.exr"}))
            firsts.push_back(job.back());
        return firsts;
    };
    CHECK(tiles_of((d / "n.<UDIM>.png").string()) == V{"o.1001.exr", "o.1004.exr", "o.1999.exr"});
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
    CHECK(tiles_of("n.<UDIM>.png") == V{"o.1001.exr", "o.1004.exr", "o.1999.exr"});
    fs::current_path(was);
    // many frames and tiles: each folder is listed once, so this is quick
    V line = {"--frames", "1-20000", (d / "n.<UDIM>.png").string(), "-o", "o.<UDIM>.#.exr"};
    const auto jobs = expand_names(line);
    REQUIRE(jobs.size() == 60000);
    CHECK(jobs.back() == V{(d / "n.1999.png").string(), "-o", "o.1999.20000.exr"});
    // a line held once per frame may not grow past 64 MiB
    line.push_back(std::string(3000, 'x'));
    line[1] = "1-99999";
    CHECK_THROWS_WITH(expand_names(line), Catch::Contains("frames hold more than 64 MiB of arguments"));
}

TEST_CASE("names: a <UDIM> set and a # sequence run one job per existing tile and frame, each as its own run",
          "[names][cli]")
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

TEST_CASE("update: a job is skipped exactly when its outputs record the digest it would write",
          "[update][cli]")
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

TEST_CASE("batch: --log strings are JSON: escapes, UTF-8 as it is, other bytes as surrogate escapes that "
          "give them back",
          "[batch][parse]")
{
    using relief::cli::json_bytes;
    using relief::cli::json_text;
    const auto text = [](const std::string& s) { return json_text(json_bytes(s)); };
    CHECK(text("") == "\"\"");
    CHECK(text("a b.exr") == "\"a b.exr\"");
    CHECK(text("say \"hi\"") == "\"say \\\"hi\\\"\"");
    CHECK(text("C:\\maps\\n.png") == "\"C:\\\\maps\\\\n.png\"");
    CHECK(text(std::string("tab\there\nnl\x01\x1f")) == "\"tab\\there\\nnl\\u0001\\u001f\"");
    CHECK(text("\x7f and caf\xc3\xa9") == "\"\x7f and caf\xc3\xa9\"");  // UTF-8 as it is
    // bytes that are not UTF-8: each one \udcXX (Python's surrogateescape)
    CHECK(text("n\xff\xfe.png") == "\"n\\udcff\\udcfe.png\"");
    CHECK(text("\xc3(") == "\"\\udcc3(\"");                      // a lead byte without its follower
    CHECK(text("\xed\xa0\x80") == "\"\\udced\\udca0\\udc80\"");  // a surrogate is not UTF-8
    CHECK(text("\xc0\xaf") == "\"\\udcc0\\udcaf\"");             // nor an overlong form
    // the plane-16 code points that stand for such bytes inside: as their bytes too
    CHECK(text("\xf4\x8f\xbf\xbf") == "\"\\udcf4\\udc8f\\udcbf\\udcbf\"");
    CHECK(text("\xf4\x8f\xbd\xbf") == "\"\xf4\x8f\xbd\xbf\"");  // U+10FF7F, just below them: as it is
    // every byte string comes back, reading \udcXX as the byte XX (what
    // Python's json.loads and os.fsencode do) and the rest as JSON
    const auto read_back = [](const std::string& json) {
        std::string bytes, fragment;
        const auto flush = [&] {
            bytes += nlohmann::json::parse("\"" + fragment + "\"").get<std::string>();
            fragment.clear();
        };
        for (std::size_t k = 1; k + 1 < json.size(); ++k) {
            if (json[k] == '\\' && json.compare(k + 1, 3, "udc") == 0) {
                flush();
                bytes += char(std::stoi(json.substr(k + 4, 2), nullptr, 16));
                k += 5;
            } else if (json[k] == '\\') {
                fragment += json.substr(k, 2);
                ++k;
            } else {
                fragment += json[k];
            }
        }
        flush();
        return bytes;
    };
    std::mt19937 rng(7);
    for (int round = 0; round < 2000; ++round) {
        std::string bytes(rng() % 12, ' ');
        for (char& c : bytes)
            c = char(rng() % 4 == 0 ? 0x80 + rng() % 0x80 : rng() % 3 == 0 ? 0xf4 : 0x01 + rng() % 0x7f);
        INFO("round " << round);
        CHECK(read_back(text(bytes)) == bytes);
    }
}

namespace {

// Per job, the seconds of its steps as -v prints them ("relief: job N:
// read F: X s", "...: --op: X s (...)", "...: -o F: X s") and the job's own
// line ("relief: job N (WHERE): ok, X s").
struct VerboseTimes {
    std::map<int, double> steps, job;
};

VerboseTimes verbose_times(const std::string& err)
{
    VerboseTimes t;
    // (a single command line's steps say no job)
    const std::regex step(R"(^relief: (?:job (\d+): )?(read .*|--[a-z]+|-o .*): ([0-9.]+) s)");
    const std::regex job(R"(^relief: job (\d+) \(.*\): ok, ([0-9.]+) s$)");
    std::istringstream in(err);
    for (std::string l; std::getline(in, l);) {
        std::smatch m;
        if (std::regex_search(l, m, step))
            t.steps[m[1].matched ? std::stoi(m[1]) : 0] += std::stod(m[3]);
        else if (std::regex_match(l, m, job))
            t.job[std::stoi(m[1])] = std::stod(m[2]);
    }
    return t;
}

}  // namespace

TEST_CASE("batch: a job's seconds in --log and -v are its own steps', written ones included", "[batch][cli]")
{
    const fs::path d = scratch("own_seconds");
    // a map whose write takes a while, then a small one (the first's write
    // goes on behind the second's work)
    const fs::path big = d / "big.exr";
    const int n = 1024;
    std::vector<float> px(std::size_t(n) * n * 3);
    for (std::size_t i = 0; i < px.size(); ++i)
        px[i] = i % 3 == 2 ? 1.0f : float((i * 2654435761u) % 1000) / 4000.0f;
    REQUIRE(relief::write_image(relief::test::image(n, n, 3, px), big.string()));
    const fs::path m = d / "jobs.txt";
    std::ofstream(m) << "'" << big.string() << "' --slopes -o '" << (d / "s0.exr").string() << "'\n"
                     << kDem << " --slopes -o '" << (d / "s1.exr").string() << "'\n";
    const fs::path log = d / "log.jsonl";
    const auto started = std::chrono::steady_clock::now();
    const auto r = run_cli("-v --batch '" + m.string() + "' --log '" + log.string() + "'");
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    INFO(r.err);
    REQUIRE(r.rc == 0);
    const VerboseTimes t = verbose_times(r.err);
    const std::vector<std::string> lines = lines_of(log);
    REQUIRE(lines.size() == 2);
    REQUIRE(t.job.size() == 2);
    double total = 0.0;
    for (int i = 0; i < 2; ++i) {
        INFO("job " << i << ": " << lines[i]);
        const double logged = nlohmann::json::parse(lines[i])["seconds"];
        // -v and the log say the same, to the log's millisecond
        CHECK(std::abs(t.job.at(i) - logged) <= 0.0015);
        // at least its steps' time (its read, its operation and its
        // write, the one done behind the next job included)
        CHECK(logged >= t.steps.at(i) - 0.004);
        total += logged;
    }
    CHECK(t.steps.at(0) > t.steps.at(1));
    CHECK(total <= wall);

    // one command line: its job's own time as well
    const fs::path log1 = d / "one.jsonl";
    const auto one = run_cli("-v '" + big.string() + "' --slopes -o '" + (d / "one.exr").string() +
                             "' --log '" + log1.string() + "'");
    INFO(one.err);
    REQUIRE(one.rc == 0);
    const VerboseTimes t1 = verbose_times(one.err);
    const std::vector<std::string> one_lines = lines_of(log1);
    REQUIRE(one_lines.size() == 1);
    const double logged = nlohmann::json::parse(one_lines[0])["seconds"];
    REQUIRE(t1.steps.count(0));
    CHECK(logged >= t1.steps.at(0) - 0.004);
}
