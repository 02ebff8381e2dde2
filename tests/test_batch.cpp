// --batch, --shard and --log: manifests of ordinary command lines run in
// one process, a failed job alone failing, shards covering every job once.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "batch.h"
#include "command_line.h"
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

} // namespace

TEST_CASE("batch: manifest lines split like a shell, without expansion", "[batch][parse]")
{
    using V = std::vector<std::string>;
    CHECK(relief::cli::split_words("a b\tc") == V{"a", "b", "c"});
    CHECK(relief::cli::split_words("  ") == V{});
    CHECK(relief::cli::split_words("# a comment") == V{});
    CHECK(relief::cli::split_words("in.png --height # trailing") == V{"in.png", "--height"});
    CHECK(relief::cli::split_words("a#b") == V{"a#b"});
    CHECK(relief::cli::split_words("'my map.png' -o \"out dir/h.exr\"") == V{"my map.png", "-o", "out dir/h.exr"});
    CHECK(relief::cli::split_words("'$HOME/*.png'") == V{"$HOME/*.png"});
    CHECK(relief::cli::split_words("$HOME *.png ~") == V{"$HOME", "*.png", "~"});
    CHECK(relief::cli::split_words(R"("a \"q\" \\ \$x \n")") == V{R"(a "q" \ $x \n)"});
    CHECK(relief::cli::split_words(R"(a\ b c\'d)") == V{"a b", "c'd"});
    CHECK(relief::cli::split_words("''") == V{""});
    CHECK(relief::cli::split_words("x'y'\"z\"") == V{"xyz"});
    CHECK_THROWS_AS(relief::cli::split_words("'open"), UsageError);
    CHECK_THROWS_AS(relief::cli::split_words("\"open"), UsageError);
    CHECK_THROWS_AS(relief::cli::split_words("tail\\"), UsageError);
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
    std::ofstream(m) << "# header\n\n" << kNormal << " --height -o a.exr\n  \n'" << kNormal << "' --slopes -o 'b c.exr'\n";
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
    CHECK_THROWS_AS(parse_command_line({"--batch", m.string(), "--log", (d / "no" / "l.jsonl").string()}), UsageError);
}

TEST_CASE("batch: jobs run in one process, a failed job alone fails, the log says what each did", "[batch][cli]")
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
    auto r = run_cli("--device cpu --batch '" + m.string() + "' --log '" + log.string() + "'");
    INFO(r.err);
    CHECK(r.rc == 1);
    CHECK(r.err.find("job 2 (" + m.string() + ":4): error: cannot read") != std::string::npos);
    CHECK(r.err.find("job 3 (" + m.string() + ":5): error: --height:rays=-3: rays=-3 must be") != std::string::npos);
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
    CHECK(lines[0].rfind("{\"job\": 0, \"line\": 2, \"args\": [\"" + kNormal + "\", \"--height:normal=opengl\", \"-o\", \"" +
                            (d / "h 0.exr").string() + "\"], \"inputs\": [\"" + kNormal + "\"], \"outputs\": [\"" +
                            (d / "h 0.exr").string() + "\"], \"status\": \"ok\", \"seconds\": ",
                        0) == 0);
    CHECK(lines[2].find("\"job\": 2, \"line\": 4,") != std::string::npos);
    CHECK(lines[2].find("\"status\": \"failed\"") != std::string::npos);
    CHECK(lines[2].find("\"message\": \"cannot read") != std::string::npos);
    CHECK(lines[3].find("\"status\": \"failed\"") != std::string::npos);
    CHECK(lines[4].find("\"status\": \"ok\"") != std::string::npos);
    CHECK(lines[4].find("\"message\": \"\"}") != std::string::npos);

    // all jobs fine: exit 0
    std::ofstream(d / "good.txt") << kDem << " --slopes -o " << (d / "g.exr").string() << "\n";
    CHECK(run_cli("--batch '" + (d / "good.txt").string() + "'").rc == 0);
    // the batch's --device reaches every job (a job's own would come after it and win)
    auto nodev = run_cli("--device 9:9 --batch '" + (d / "good.txt").string() + "'");
    CHECK(nodev.rc == 1);
    CHECK(nodev.err.find("job 0 (") != std::string::npos);
    CHECK(nodev.err.find("no OpenCL device 9:9") != std::string::npos);
    std::ofstream(d / "own.txt") << "--device cpu " << kDem << " --slopes -o " << (d / "g2.exr").string() << "\n";
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
        auto r = run_cli("--batch '" + m.string() + "' --shard " + std::to_string(s) + "/3 --log '" + log.string() + "'");
        INFO(r.err);
        REQUIRE(r.rc == 0);
        CHECK(r.err.find("2 ok, 0 skipped, 0 failed of 2 job(s) (shard " + std::to_string(s) + "/3 of 6)") != std::string::npos);
        for (const std::string& l : lines_of(log)) {
            const int job = std::stoi(l.substr(std::string("{\"job\": ").size()));
            CHECK(job % 3 == s);
            done.insert(job);
        }
    }
    CHECK(done == std::multiset<int>{0, 1, 2, 3, 4, 5});
    for (int i = 0; i < 6; ++i)
        CHECK(fs::exists(d / ("s" + std::to_string(i) + ".exr")));
}
