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
#include "farm/farm_test.h"

using namespace relief::test::farm;

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

TEST_CASE("batch: jobs overlap (reads ahead, writes behind), yet each job's lines, record and failure "
          "stay its own",
          "[batch][cli][slow]")
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

TEST_CASE("batch: a manifest line that is not a job fails alone, saying what a job is", "[batch][cli]")
{
    const fs::path d = scratch("not_jobs");
    const fs::path m = d / "jobs.txt";
    std::ofstream(m) << "--version\n--help\n--list-devices\n-v\n--log '" << (d / "l.jsonl").string() << "' "
                     << kDem << " --slopes -o '" << (d / "s.exr").string() << "'\n--batch '" << m.string()
                     << "'\n";
    const auto r = run_cli("--batch '" + m.string() + "'");
    INFO(r.err);
    CHECK(r.rc == 1);
    for (int job = 0; job < 6; ++job)
        CHECK(r.err.find("job " + std::to_string(job) + " (" + m.string() + ":" + std::to_string(job + 1) +
                         "): error: a job is images, operations and outputs") != std::string::npos);
    CHECK(r.err.find("0 ok, 0 skipped, 6 failed of 6 job(s)") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "s.exr"));
    CHECK_FALSE(fs::exists(d / "l.jsonl"));
}

TEST_CASE("batch: a job's record lists its mask among the inputs and its report among the outputs",
          "[batch][cli]")
{
    const fs::path d = scratch("record_files");
    const OIIO::ImageSpec spec = OIIO::ImageInput::open(kDem)->spec();
    const fs::path mask = d / "mask.exr";
    REQUIRE(relief::write_image(
        relief::test::image(spec.width, spec.height, 1,
                            std::vector<float>(std::size_t(spec.width) * spec.height, 1.0f)),
        mask.string()));
    const fs::path h = d / "h.exr", report = d / "r.json", log = d / "l.jsonl";
    const auto r = run_cli(kDem + " --height:mask='" + mask.string() + "' -o '" + h.string() +
                           "' --report '" + report.string() + "' --log '" + log.string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    const std::vector<std::string> lines = lines_of(log);
    REQUIRE(lines.size() == 1);
    const nlohmann::json j = nlohmann::json::parse(lines[0]);
    CHECK(j["args"] == nlohmann::json::array({kDem, "--height:mask=" + mask.string(), "-o", h.string(),
                                              "--report", report.string(), "--log", log.string()}));
    CHECK(j["inputs"] == nlohmann::json::array({kDem, mask.string()}));
    CHECK(j["outputs"] == nlohmann::json::array({h.string(), report.string()}));
}

TEST_CASE("batch: a single run refused before it starts still leaves its failed --log record",
          "[batch][cli][errors]")
{
    const fs::path d = scratch("refused_logged");
    const fs::path log = d / "l.jsonl", h = d / "h.exr", n = d / "n.png";
    fs::copy_file(kNormal, n, fs::copy_options::overwrite_existing);
    fs::remove(log);
    const std::string at = " -o '" + h.string() + "' --log '" + log.string() + "'";
    struct Case {
        std::string args, said;
    };
    const std::vector<Case> cases = {
        {"'" + (d / "missing.png").string() + "' --height" + at, "cannot read '"},
        {"'" + n.string() + "' --height:bogus=1" + at, "unknown modifier 'bogus'"},
        {"'" + n.string() + "' --height:mask='" + (d / "nomask.png").string() + "'" + at, "no such file"},
        {"'" + n.string() + "' --height -o '" + n.string() + "' --update --log '" + log.string() + "'",
         "an -o output is also its input"},
    };
    for (const Case& c : cases) {
        const auto r = run_cli(c.args);
        INFO(c.args << "\n" << r.err);
        CHECK(r.rc == 2);
        CHECK(r.err.find(c.said) != std::string::npos);
    }
    const std::vector<std::string> lines = lines_of(log);
    REQUIRE(lines.size() == cases.size());
    for (std::size_t i = 0; i < lines.size(); ++i) {
        INFO(lines[i]);
        const nlohmann::json j = nlohmann::json::parse(lines[i]);
        CHECK(j["status"] == "failed");
        CHECK(j["message"].get<std::string>().find(cases[i].said) != std::string::npos);
        CHECK(j["args"].size() >= 5);
    }
    // Never into a file the line names otherwise: --log onto the input, or
    // onto an output not yet made, is no record of the refusal.
    const std::string before = relief::test::slurp(n);
    CHECK(run_cli("'" + n.string() + "' --height:bogus=1 -o '" + h.string() + "' --log '" + n.string() + "'")
              .rc == 2);
    CHECK(relief::test::slurp(n) == before);
    CHECK(run_cli("'" + n.string() + "' --height:bogus=1 -o '" + h.string() + "' --log '" +
                  (d / "." / "h.exr").string() + "'")
              .rc == 2);
    CHECK(!fs::exists(h));
    // ... nor onto a file a modifier names (mask=): the mask stays as it was.
    const fs::path mask = d / "mask.png";
    fs::copy_file(kNormal, mask, fs::copy_options::overwrite_existing);
    const std::string mask_before = relief::test::slurp(mask);
    CHECK(run_cli("'" + n.string() + "' --height:mask='" + mask.string() + "':bogus=1 -o '" + h.string() +
                  "' --log '" + mask.string() + "'")
              .rc == 2);
    CHECK(relief::test::slurp(mask) == mask_before);
    // A dry run writes no log, refused or not.
    CHECK(run_cli("'" + n.string() + "' --height:bogus=1 --dry-run" + at).rc == 2);
    CHECK(lines_of(log).size() == cases.size());
    CHECK(!fs::exists(h));
    // A batch refused before any job (a manifest line that does not parse)
    // leaves its failed record too.
    {
        std::ofstream m(d / "jobs.txt");
        m << "'" << n.string() << " --height -o '" << h.string() << "'\n";  // (a quote left open)
    }
    const fs::path batch_log = d / "batch.jsonl";
    fs::remove(batch_log);
    const auto r = run_cli("--batch '" + (d / "jobs.txt").string() + "' --log '" + batch_log.string() + "'");
    INFO(r.err);
    CHECK(r.rc == 2);
    const std::vector<std::string> batch_lines = lines_of(batch_log);
    REQUIRE(batch_lines.size() == 1);
    const nlohmann::json refused = nlohmann::json::parse(batch_lines[0]);
    CHECK(refused["status"] == "failed");
    CHECK(refused["message"].get<std::string>().find("unterminated ' quote") != std::string::npos);
}

TEST_CASE("batch: a single --dry-run prints its plan and writes no --log", "[batch][cli]")
{
    const fs::path d = scratch("single_dry_run");
    const fs::path log = d / "l.jsonl", h = d / "h.exr";
    fs::remove(log);
    const auto r =
        run_cli("'" + kNormal + "' --height -o '" + h.string() + "' --dry-run --log '" + log.string() + "'");
    INFO(r.out << r.err);
    CHECK(r.rc == 0);
    CHECK(r.out.find("\"status\":\"pending\"") != std::string::npos);
    CHECK(r.err.find("1 pending, 0 skipped, 0 failed of 1 job(s) (dry run)") != std::string::npos);
    CHECK(!fs::exists(log));
    CHECK(!fs::exists(h));
}

TEST_CASE("batch: a malformed RELIEF_MEMORY_LIMIT is a usage error, said once before any job",
          "[batch][cli][errors]")
{
    const fs::path d = scratch("memory_limit_malformed");
    for (int i = 0; i < 3; ++i)
        write_crop(kNormal, d / ("n" + std::to_string(i) + ".png"), 8 * i, 64);
    {
        std::ofstream m(d / "jobs.txt");
        for (int i = 0; i < 3; ++i)
            m << "n" << i << ".png --height -o h" << i << ".exr\n";
    }
    for (const std::string& args : {std::string("--batch jobs.txt --log l.jsonl"),
                                    std::string("n0.png --height -o h0.exr --log l.jsonl")}) {
        INFO(args);
        const auto r = run_cli(args, "cd '" + d.string() + "' && RELIEF_MEMORY_LIMIT=10x");
        INFO(r.err);
        CHECK(r.rc == 2);
        CHECK(
            r.err ==
            "relief: error: RELIEF_MEMORY_LIMIT must be a size in bytes > 0: a number, or with K, M, G or T "
            "(KiB... TiB: powers of 1024) or kB, MB, GB or TB (powers of 1000), not '10x'\n");
        CHECK(!fs::exists(d / "h0.exr"));
    }
    CHECK(statuses(d / "l.jsonl") == std::vector<std::string>{"failed", "failed"});
}
