// SPDX-License-Identifier: Apache-2.0
// Outputs under abuse: exclusive hidden temporary files, removed when the
// run is interrupted and, after a SIGKILL, by the next run into the folder;
// logs that many batches share; names refused before the work.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <random>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include "relief/relief.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/taken_names.h"
#include "support/run_cli.h"

namespace fs = std::filesystem;
using relief::test::run_cli;
using relief::test::slurp;

namespace {

const std::string kSampleNormal = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";

// relief's temporary files in `dir`, or any name with "relief-tmp".
std::vector<std::string> temporaries(const fs::path& dir)
{
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path().filename().string().find("relief-tmp") != std::string::npos)
            names.push_back(e.path().filename().string());
    return names;
}

// The fields relief puts into temporary names (see relief/output_files.h).
std::string this_host()
{
    char name[256] = {};
    ::gethostname(name, sizeof name - 1);
    std::string s(name);
    for (char& c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_'))
            c = '_';
    return s.substr(0, 64);
}

std::string this_pid_namespace()
{
    struct stat st {};
    REQUIRE(::stat("/proc/self/ns/pid", &st) == 0);
    return std::to_string(static_cast<unsigned long long>(st.st_ino));
}

// A process id that no process has now: a child's, once reaped.
long dead_pid()
{
    const pid_t pid = ::fork();
    if (pid == 0)
        ::_exit(0);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return pid;
}

// Starts the relief executable with `args` (no shell), stdout and stderr to
// /dev/null, in `dir`. Everything is prepared before the fork: the child of
// a process with OIIO's and OpenCL's threads may only make system calls
// until it execs (a lock another thread held, malloc's or stdio's, stays
// held in the child: this hung once).
pid_t start_cli(const fs::path& dir, const std::vector<std::string>& args)
{
    std::vector<char*> argv{const_cast<char*>(RELIEF_CLI)};
    for (const std::string& a : args)
        argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const std::string folder = dir.string();
    const pid_t pid = ::fork();
    if (pid == 0) {
        const int null = ::open("/dev/null", O_WRONLY);
        if (::chdir(folder.c_str()) != 0 || null < 0 || ::dup2(null, 1) < 0 || ::dup2(null, 2) < 0)
            ::_exit(3);
        ::execv(RELIEF_CLI, argv.data());
        ::_exit(4);
    }
    return pid;
}

// Waits for `pid`: its exit status, or 128 + the signal that killed it.
int wait_for(pid_t pid)
{
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// A 2048^2 RGB float map: its OpenEXR output is 48 MiB, long enough to
// catch the temporary file on disk.
fs::path big_input(const fs::path& dir)
{
    const int n = 2048;
    std::vector<float> px(std::size_t(n) * n * 3);
    for (std::size_t i = 0; i < px.size(); ++i)
        px[i] = float((i * 2654435761u) % 1000) / 1000.0f;
    const fs::path p = dir / "big.exr";
    REQUIRE(relief::write_image(relief::test::image(n, n, 3, px), p.string()));
    return p;
}

// Waits (up to 60 s) until a temporary file is in `dir`; false if the
// process `pid` ended first.
bool temporary_appears(const fs::path& dir, pid_t pid)
{
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < until) {
        if (!temporaries(dir).empty())
            return true;
        int status = 0;
        if (::waitpid(pid, &status, WNOHANG) == pid)
            return false;
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    return false;
}

}  // namespace

TEST_CASE(
    "output files: hidden exclusive temporary names, stale ones of gone processes removed, others' kept",
    "[io][files]")
{
    const fs::path d = relief::test::scratch("output_files/stale");
    const std::string host = this_host(), ns = this_pid_namespace();
    const std::string mine = "-" + ns + "-";
    const std::vector<std::string> stale = {
        ".h.exr.relief-tmp-" + host + mine + std::to_string(dead_pid()) + "-0123456789abcdef",
        ".long name.exr.relief-tmp-" + host + mine + std::to_string(dead_pid()) + "-00000000000000ff",
    };
    const std::vector<std::string> kept = {
        // alive: this process and its parent
        ".a.exr.relief-tmp-" + host + mine + std::to_string(::getppid()) + "-0123456789abcdef",
        // another host on a shared file system, another PID namespace
        ".b.exr.relief-tmp-otherhost" + mine + std::to_string(dead_pid()) + "-0123456789abcdef",
        ".c.exr.relief-tmp-" + host + "-1-" + std::to_string(dead_pid()) + "-0123456789abcdef",
        // not relief's: not hidden, or not of its form
        "d.exr.relief-tmp-" + host + mine + std::to_string(dead_pid()) + "-0123456789abcdef",
        ".e.exr.relief-tmp-" + host + mine + "x12-0123456789abcdef",
        "h.exr",
    };
    for (const auto& names : {stale, kept})
        for (const std::string& n : names)
            std::ofstream(d / n) << "partial";
    // The first write into the folder sweeps it once.
    const OIIO::ImageBuf img = relief::test::image(4, 4, 1, std::vector<float>(16, 0.5f));
    REQUIRE(relief::write_image(img, (d / "out.exr").string()));
    for (const std::string& n : stale)
        CHECK_FALSE(fs::exists(d / n));
    for (const std::string& n : kept)
        CHECK(fs::exists(d / n));
    // Nothing of the write itself is left, and a second sweep finds nothing.
    CHECK(temporaries(d).size() == kept.size() - 1);
    CHECK(relief::remove_stale_temporary_files(d.string()) == 0);
    // Written text is whole and leaves no temporary either.
    REQUIRE(relief::write_text_file((d / "r.json").string(), "{}\n"));
    CHECK(slurp(d / "r.json") == "{}\n");
    CHECK(temporaries(d).size() == kept.size() - 1);
}

TEST_CASE("output files: a temporary name another writer took is passed over, eight in a row fail",
          "[io][files]")
{
    const fs::path d = relief::test::scratch("output_files/taken");
    for (int taken : {1, 7}) {
        INFO(taken << " taken");
        const fs::path out = d / ("r" + std::to_string(taken) + ".json");
        relief::test::take_temporary_names(taken);
        REQUIRE(relief::write_text_file(out.string(), "{}\n"));
        CHECK(slurp(out) == "{}\n");
        // each try drew a name of its own; the other writer's files stay
        const std::vector<std::string> names = relief::test::temporary_names_taken();
        CHECK(names.size() == std::size_t(taken));
        CHECK(std::set<std::string>(names.begin(), names.end()).size() == names.size());
        for (const std::string& n : names)
            CHECK(fs::exists(n));
    }
    relief::test::take_temporary_names(8);
    const fs::path never = d / "never.json";
    CHECK_FALSE(relief::write_text_file(never.string(), "{}\n"));
    CHECK(relief::geterror().find("no free temporary name in '" + d.string() + "'") != std::string::npos);
    CHECK_FALSE(fs::exists(never));
    CHECK(relief::test::temporary_names_taken().size() == 8);
    relief::test::take_temporary_names(0);
    // any other reason is the system's, at once, without another try
    std::ofstream(d / "file") << "x";
    for (const auto& [where, why] :
         {std::pair<fs::path, std::string>{d / "absent" / "r.json", "No such file"},
          {d / "file" / "r.json", "Not a directory"}}) {
        INFO(where);
        CHECK_FALSE(relief::write_text_file(where.string(), "{}\n"));
        CHECK(relief::geterror().find(why) != std::string::npos);
        CHECK(relief::geterror().find("no free temporary name") == std::string::npos);
    }
}

TEST_CASE(
    "output files: SIGTERM and SIGINT remove the temporary file and exit 128+signal, after SIGKILL the next "
    "run removes it",
    "[io][files][cli][slow]")
{
    const fs::path d = relief::test::scratch("output_files/signals");
    const fs::path in = big_input(d);
    const std::string old = "the previous output, which must survive\n";
    for (int sig : {SIGTERM, SIGINT, SIGKILL}) {
        INFO("signal " << sig);
        std::ofstream(d / "out.exr") << old;
        const pid_t pid = start_cli(d, {in.string(), "--slopes", "-o", "out.exr"});
        REQUIRE(temporary_appears(d, pid));
        // hidden, and no glob of the extension matches it
        for (const std::string& n : temporaries(d)) {
            CHECK(n.front() == '.');
            CHECK(n.find(".exr", n.size() - 4) == std::string::npos);
        }
        ::kill(pid, sig);
        CHECK(wait_for(pid) == 128 + sig);
        CHECK(slurp(d / "out.exr") == old);
        if (sig == SIGKILL) {
            CHECK(temporaries(d).size() == 1);  // nobody can remove it now...
            auto r = run_cli("'" + in.string() + "' --slopes -o '" + (d / "out.exr").string() + "'");
            REQUIRE(r.rc == 0);
            CHECK(slurp(d / "out.exr") != old);
        }
        CHECK(temporaries(d).empty());  // ...but the next run into the folder does
    }
    // After more outputs than the signal handler keeps (64 at once), each
    // let go once written, the next one is still removed on a signal.
    const fs::path many = relief::test::scratch("output_files/signals_many");
    const fs::path small = many / "small.exr";
    REQUIRE(relief::write_image(relief::test::image(4, 4, 3, std::vector<float>(48, 0.5f)), small.string()));
    std::vector<std::string> args = {small.string(), "--slopes"};
    for (int i = 0; i < 70; ++i)
        args.insert(args.end(), {"-o", (many / ("s" + std::to_string(i) + ".exr")).string()});
    args.insert(args.end(), {in.string(), "--slopes", "-o", "out.exr"});
    std::ofstream(d / "out.exr") << old;
    const pid_t pid = start_cli(d, args);
    REQUIRE(temporary_appears(d, pid));
    CHECK(fs::exists(many / "s69.exr"));
    ::kill(pid, SIGTERM);
    CHECK(wait_for(pid) == 128 + SIGTERM);
    CHECK(slurp(d / "out.exr") == old);
    CHECK(temporaries(d).empty());
}

TEST_CASE("output files: batches sharing one --log append whole lines, none lost or torn",
          "[batch][files][cli][slow]")
{
    const fs::path d = relief::test::scratch("output_files/shared_log");
    // Jobs that fail at once (a missing input): no device, many records.
    const int jobs = 300;
    {
        std::ofstream m(d / "jobs.txt");
        for (int i = 0; i < jobs; ++i)
            m << "missing" << i << ".png --height -o h" << i << ".exr\n";
    }
    for (int writers : {2, 8}) {
        INFO(writers << " batches at once");
        const fs::path log = d / ("log" + std::to_string(writers) + ".jsonl");
        std::ofstream(log) << "{\"earlier\": true}\n";  // appended to, never replaced
        std::vector<pid_t> pids;
        for (int w = 0; w < writers; ++w)
            pids.push_back(start_cli(d, {"--batch", "jobs.txt", "--log", log.string()}));
        for (pid_t p : pids)
            CHECK(wait_for(p) == 1);  // every job failed
        std::ifstream f(log);
        std::string line;
        std::multiset<int> seen;
        int lines = 0;
        std::getline(f, line);
        CHECK(line == "{\"earlier\": true}");
        while (std::getline(f, line)) {
            ++lines;
            // whole records: one object per line, its job and its status
            REQUIRE(line.rfind("{\"job\":", 0) == 0);
            REQUIRE(line.back() == '}');
            CHECK(line.find("\"status\":\"failed\"") != std::string::npos);
            seen.insert(std::stoi(line.substr(7)));
        }
        CHECK(lines == writers * jobs);
        for (int i = 0; i < jobs; ++i)
            CHECK(seen.count(i) == std::size_t(writers));
    }
}

TEST_CASE("output files: a name the file system cannot take is refused before the work", "[io][files][cli]")
{
    const fs::path d = relief::test::scratch("output_files/names");
    const std::string& in = kSampleNormal;
    // 255 bytes is the longest name: it is written (its temporary name is
    // shorter); 256 is refused at once, with the numbers.
    const std::string longest = std::string(251, 'h') + ".exr", too_long = std::string(252, 'h') + ".exr";
    auto r = run_cli("'" + in + "' --slopes -o '" + (d / longest).string() + "'");
    INFO(r.err);
    CHECK(r.rc == 0);
    CHECK(fs::exists(d / longest));
    r = run_cli("-v '" + in + "' --slopes -o '" + (d / too_long).string() + "'");
    CHECK(r.rc != 0);
    CHECK(r.err.find("the file name is 256 bytes, longer than its file system allows (255)") !=
          std::string::npos);
    CHECK(r.err.find("slopes:") == std::string::npos);  // no step ran
    CHECK(temporaries(d).empty());
}

TEST_CASE(
    "output files: a device node, FIFO or socket as any output is refused before the work, left as it was",
    "[io][files][cli]")
{
    const fs::path d = relief::test::scratch("output_files/nodes");
    // Private nodes in the scratch folder, never the machine's own /dev.
    struct Node {
        fs::path path;
        const char* said;
        fs::file_type type;
    };
    std::vector<Node> nodes;
    const fs::path fifo = d / "fifo.exr";
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    nodes.push_back({fifo, "it is a FIFO", fs::file_type::fifo});
    const fs::path sock = d / "sock.exr";
    const int s = ::socket(AF_UNIX, SOCK_STREAM, 0);
    REQUIRE(s >= 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    REQUIRE(sock.string().size() < sizeof addr.sun_path);
    std::strcpy(addr.sun_path, sock.c_str());
    REQUIRE(::bind(s, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0);
    nodes.push_back({sock, "it is a socket", fs::file_type::socket});
    // A character device (the numbers of /dev/null), where mknod is allowed
    // (root; CI runs as root).
    const fs::path dev = d / "null.exr";
    if (::mknod(dev.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0)
        nodes.push_back({dev, "it is a character device", fs::file_type::character});
    else
        WARN("mknod is not allowed here: the device node is left out");
    // A link to the FIFO: stat follows it.
    const fs::path link = d / "link.exr";
    fs::create_symlink(fifo, link);
    nodes.push_back({link, "it is a FIFO", fs::file_type::fifo});

    const std::string in = "'" + kSampleNormal + "'";
    for (const Node& n : nodes) {
        const std::string at = "'" + n.path.string() + "'";
        for (const std::string& args :
             {in + " --slopes -o " + at,
              in + " --height --report " + at + " -o '" + (d / "h.exr").string() + "'",
              in + " --slopes --log " + at + " -o '" + (d / "s.exr").string() + "'",
              in + " --height --mesh:out=" + at}) {
            INFO(args);
            const auto r = run_cli("-v " + args);
            INFO(r.err);
            CHECK(r.rc == 2);
            CHECK(r.err.find(n.said) != std::string::npos);
            CHECK(r.err.find("relief writes only regular files or new names") != std::string::npos);
            CHECK(r.err.find("slopes:") == std::string::npos);  // no step ran
            CHECK(fs::status(n.path).type() == n.type);
        }
    }
    CHECK(fs::is_symlink(link));
    CHECK(temporaries(d).empty());
    CHECK(!fs::exists(d / "h.exr"));
    CHECK(!fs::exists(d / "s.exr"));
    // The library refuses it too.
    const OIIO::ImageBuf img = relief::test::image(4, 4, 1, std::vector<float>(16, 0.5f));
    CHECK(!relief::write_image(img, fifo.string()));
    CHECK(relief::geterror().find("it is a FIFO") != std::string::npos);
    CHECK(!relief::write_text_file(fifo.string(), "{}"));
    CHECK(relief::geterror().find("it is a FIFO") != std::string::npos);
    CHECK(fs::is_fifo(fifo));
    ::close(s);
}

TEST_CASE("output files: a write that fails part way leaves no descriptor open and no temporary file",
          "[io][files]")
{
    const fs::path d = relief::test::scratch("output_files/failed_write");
    const auto open_descriptors = [] {
        return std::distance(fs::directory_iterator("/proc/self/fd"), fs::directory_iterator());
    };
    // The file size limit (EFBIG, SIGXFSZ ignored) fails the write after
    // its first 4 KiB, as a full disk would.
    struct sigaction ignore {
    }, was{};
    ignore.sa_handler = SIG_IGN;
    REQUIRE(::sigaction(SIGXFSZ, &ignore, &was) == 0);
    rlimit limit{}, small{};
    REQUIRE(::getrlimit(RLIMIT_FSIZE, &limit) == 0);
    small = limit;
    small.rlim_cur = 4096;
    const auto before = open_descriptors();
    REQUIRE(::setrlimit(RLIMIT_FSIZE, &small) == 0);
    const bool written = relief::write_text_file((d / "big.json").string(), std::string(1 << 20, 'x'));
    ::setrlimit(RLIMIT_FSIZE, &limit);
    ::sigaction(SIGXFSZ, &was, nullptr);
    CHECK_FALSE(written);
    CHECK(relief::geterror().find("cannot write '") != std::string::npos);
    CHECK(open_descriptors() == before);
    CHECK_FALSE(fs::exists(d / "big.json"));
    CHECK(temporaries(d).empty());
}

TEST_CASE(
    "output files: a write that would clobber an input, the manifest or another output is refused before "
    "any work",
    "[files][cli][parse][slow]")
{
    const fs::path d = relief::test::scratch("output_files/clobber");
    const std::string in = (d / "in.png").string();
    fs::copy_file(kSampleNormal, in);
    const std::string original = slurp(in);
    fs::create_directories(d / "sub");
    {
        std::ofstream m(d / "jobs.txt");
        m << "in.png --slopes -o s0.exr\n";
    }
    const std::string manifest_text = slurp(d / "jobs.txt");
    struct Case {
        std::string args, message;
    };
    const std::vector<Case> refused = {
        {"--batch jobs.txt --log jobs.txt", "'jobs.txt': the --log file would replace the --batch file"},
        {"in.png --slopes -o s.exr --log in.png", "the --log file would replace an input"},
        {"in.png --height --report in.png", "the --report file would replace an input"},
        {"in.png --height -o h.exr --report h.exr", "it is both an -o output and the --report file"},
        {"in.png --height -o h.exr --report sub/../h.exr", "it is both an -o output and the --report file"},
        {"in.png --height -o h.exr --log ./h.exr", "it is both the --log file and an -o output"},
        {"in.png --height -o h.exr -o h.exr", "it is both an -o output and an -o output"},
        {"in.png --height --mesh:out=m.ply --report m.ply",
         "it is both an operation's output file (out=) and the --report file"},
        {"--update in.png --slopes -o in.png", "an -o output is also its input: under --update"},
        // a mask or map is no image being edited in place
        {"in.png --height:mask=in.png -o in.png",
         "an -o output would replace a file an operation reads (mask=, fix=, env=) of the same command line"},
        {"in.png --dup --height -o h.exr --correct:fix=in.png -o in.png",
         "an -o output would replace a file an operation reads (mask=, fix=, env=)"},
    };
    for (const Case& c : refused) {
        INFO("relief " << c.args);
        auto r = run_cli(c.args, "cd '" + d.string() + "' &&");
        INFO(r.err);
        CHECK(r.rc == 2);
        CHECK(r.err.find(c.message) != std::string::npos);
        CHECK(r.err.find("nothing was run") != std::string::npos);
        CHECK(slurp(in) == original);
        CHECK(slurp(d / "jobs.txt") == manifest_text);
        CHECK_FALSE(fs::exists(d / "h.exr"));
        CHECK_FALSE(fs::exists(d / "s.exr"));
    }
    // A hard link is the same file under another name.
    fs::create_hard_link(d / "in.png", d / "link.png");
    auto r = run_cli("link.png --height --report in.png", "cd '" + d.string() + "' &&");
    CHECK(r.rc == 2);
    CHECK(r.err.find("'link.png' and 'in.png' are one file: the --report file would replace an input") !=
          std::string::npos);
    // Two jobs of a manifest writing one file: refused, both lines named,
    // whatever the shard (the shards run at once).
    {
        std::ofstream m(d / "two.txt");
        m << "in.png --slopes -o s.exr\n# a comment\nin.png --height -o s.exr\n";
    }
    r = run_cli("--batch two.txt --shard 1/2", "cd '" + d.string() + "' &&");
    CHECK(r.rc == 2);
    CHECK(r.err.find("it is both an -o output of job 0 (line 1) and an -o output of job 1 (line 3)") !=
          std::string::npos);
    CHECK_FALSE(fs::exists(d / "s.exr"));
    // Allowed: an image written over its own input (oiiotool's in-place
    // edit), and one job's output read by another job.
    fs::copy_file(d / "in.png", d / "copy.png");
    r = run_cli("copy.png --slopes -d uint16 -o copy.png", "cd '" + d.string() + "' &&");
    INFO(r.err);
    CHECK(r.rc == 0);
    CHECK(slurp(d / "copy.png") != original);
}

TEST_CASE("output files: a one-texel-wide or one-row image cut short loses its digest", "[io][files]")
{
    // The thinnest maps too: the check reads their last scanline or strip.
    const fs::path d = relief::test::scratch("output_files/thin_truncated");
    const std::string digest = "0123456789abcdef0123456789abcdef";
    for (const char* name : {"tall.exr", "tall.tif", "wide.exr", "wide.tif"}) {
        INFO(name);
        const bool tall = name[0] == 't';
        const int w = tall ? 1 : 256, h = tall ? 256 : 1;
        OIIO::ImageBuf img = relief::test::image(w, h, 1, relief::test::random_field(256, 3u, 0.0f, 1.0f));
        img.specmod().attribute("compression", "none");
        img.specmod().attribute("relief:digest", digest);
        img.specmod().attribute("ImageDescription", "relief:digest=" + digest);
        const fs::path f = d / name;
        REQUIRE(img.write(f.string()));
        REQUIRE(relief::recorded_digest(f.string()) == digest);
        fs::resize_file(f, fs::file_size(f) - 4);  // the last pixel's bytes
        CHECK(relief::recorded_digest(f.string()).empty());
    }
}

TEST_CASE("output files: --update recomputes an output damaged inside, its size kept, in every type",
          "[batch][files][cli][slow]")
{
    const fs::path d = relief::test::scratch("output_files/damaged_inside");
    // A height (1 channel) in each lossless format relief writes and each
    // type: up to date as written; 64 bytes changed mid-file (the header
    // and the size kept) make it stale, uncompressed floats included. The
    // 16 jobs run as one batch (--update decides per job, as in a run of
    // its own), 4 processes instead of 64.
    std::vector<std::string> names, types;
    {
        std::ofstream jobs(d / "jobs.txt");
        for (const char* ext : {"exr", "tif", "tiff", "png"})  // (.tiff: TIFF's other name, stored alike)
            for (const char* type : {"float", "half", "uint16", "uint8"}) {
                names.push_back("h" + std::to_string(names.size()) + "." + ext);
                types.push_back(type);
                jobs << "'" << kSampleNormal << "' --height -d " << type << " -o " << names.back() << "\n";
            }
    }
    // Each job's status in the batch's log, in job order.
    const auto statuses = [&] {
        fs::remove(d / "log.jsonl");
        const auto r = run_cli("--batch jobs.txt --update --log log.jsonl", "cd '" + d.string() + "' &&");
        INFO(r.err);
        CHECK(r.rc == 0);
        std::vector<std::string> status(names.size());
        std::istringstream log(slurp(d / "log.jsonl"));
        for (std::string line; std::getline(log, line);) {
            const auto record = nlohmann::json::parse(line);
            const std::size_t job = record.at("job");
            REQUIRE(job < status.size());
            status[job] = record.at("status");
        }
        return status;
    };
    const auto all = [&](const std::vector<std::string>& status, const std::string& expected) {
        for (std::size_t i = 0; i < names.size(); ++i) {
            INFO(names[i] << " -d " << types[i]);
            CHECK(status[i] == expected);
        }
    };
    all(statuses(), "ok");
    all(statuses(), "skipped");
    for (const std::string& name : names) {
        std::string bytes = slurp(d / name);
        const std::size_t mid = bytes.size() / 2;
        for (std::size_t i = mid; i < mid + 64; ++i)
            bytes[i] = char(bytes[i] ^ 0x5a);
        std::ofstream(d / name, std::ios::binary) << bytes;
        INFO(name);
        CHECK(relief::recorded_digest((d / name).string()).empty());
    }
    all(statuses(), "ok");
    all(statuses(), "skipped");
}

TEST_CASE("output files: --update recomputes an output cut short, whatever keeps its header",
          "[batch][files][cli][slow]")
{
    const fs::path d = relief::test::scratch("output_files/truncated");
    const std::string& in = kSampleNormal;
    for (const char* name : {"s.exr", "s.tif", "s.png"}) {
        INFO(name);
        const std::string cmd = "--update --log log.jsonl '" + in + "' --slopes -d uint16 -o " + name;
        const auto run = [&] {
            fs::remove(d / "log.jsonl");
            auto r = run_cli(cmd, "cd '" + d.string() + "' &&");
            INFO(r.err);
            CHECK(r.rc == 0);
            return slurp(d / "log.jsonl");
        };
        CHECK(run().find("\"status\":\"ok\"") != std::string::npos);
        CHECK(run().find("\"status\":\"skipped\"") != std::string::npos);
        const auto size = fs::file_size(d / name);
        fs::resize_file(d / name, size / 2);  // the header and the digest stay
        CHECK(relief::recorded_digest((d / name).string()).empty());
        CHECK(run().find("\"status\":\"ok\"") != std::string::npos);
        CHECK(fs::file_size(d / name) == size);
    }
}

TEST_CASE(
    "output files: a --batch --update killed at random moments and rerun ends whole, as a clean run, with "
    "no litter",
    "[batch][files][cli][slow]")
{
    const fs::path d = relief::test::scratch("output_files/kills");
    const std::string& in = kSampleNormal;
    fs::create_directories(d / "out");
    {
        std::ofstream m(d / "jobs.txt");
        for (int i = 0; i < 6; ++i)
            m << "'" << in << "' --slopes -o out/s" << i << ".exr\n";
        m << "'" << in << "' --height -o out/h.exr -o out/h.png\n";
    }
    const std::vector<std::string> args = {"--batch", "jobs.txt", "--update", "--log", "log.jsonl"};
    // A clean run: the reference, and how long a run takes.
    auto t0 = std::chrono::steady_clock::now();
    REQUIRE(wait_for(start_cli(d, args)) == 0);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::vector<std::pair<fs::path, std::vector<float>>> clean;
    for (const auto& e : fs::directory_iterator(d / "out"))
        clean.emplace_back(e.path(), relief::test::file_pixels(e.path()));
    REQUIRE(clean.size() == 8);
    // Kill at moments spread over a run, each after removing some outputs
    // (so that every rerun has work to do) and damaging one.
    std::mt19937 random(24);
    for (int k = 0; k < 12; ++k) {
        INFO("kill " << k);
        for (std::size_t i = 0; i < clean.size(); ++i)
            if ((i + k) % 3 == 0)
                fs::remove(clean[i].first);
        const pid_t pid = start_cli(d, args);
        std::this_thread::sleep_for(std::chrono::duration<double>(
            std::uniform_real_distribution<double>(0.05, 1.0)(random) * seconds));
        ::kill(pid, SIGKILL);
        wait_for(pid);
    }
    fs::remove(d / "log.jsonl");
    REQUIRE(wait_for(start_cli(d, args)) == 0);
    for (const auto& [path, pixels] : clean) {
        INFO(path);
        REQUIRE(fs::exists(path));
        CHECK(relief::test::file_pixels(path) == pixels);
    }
    CHECK(temporaries(d / "out").empty());
    // The last run's log: one whole record per job, each ok or skipped.
    std::ifstream f(d / "log.jsonl");
    std::string line;
    int records = 0;
    while (std::getline(f, line)) {
        ++records;
        CHECK(line.rfind("{\"job\":", 0) == 0);
        CHECK(line.back() == '}');
        CHECK(line.find("\"status\":\"failed\"") == std::string::npos);
    }
    CHECK(records == 7);
}

TEST_CASE("output files: two writers of one output in separate PID namespaces leave one whole result",
          "[files][cli][slow]")
{
    // In containers every process can be PID 1: the temporary names differ
    // by the PID namespace, so neither writer opens the other's file.
    if (::geteuid() != 0 || std::system("unshare -p -f true 2>/dev/null") != 0) {
        relief::test::mark_skipped("needs root and unshare -p (PID namespaces)");
        return;
    }
    const fs::path d = relief::test::scratch("output_files/namespaces");
    const fs::path a = big_input(d);
    // Another map of the same size: a mirror of the first.
    OIIO::ImageBuf mirrored;
    REQUIRE(relief::read_image(mirrored, a.string()));
    std::vector<float> px = relief::test::pixels(mirrored);
    std::reverse(px.begin(), px.end());
    const fs::path b = d / "big_b.exr";
    REQUIRE(relief::write_image(relief::test::image(2048, 2048, 3, px), b.string()));
    for (const fs::path& input : {a, b})
        REQUIRE(run_cli("'" + input.string() + "' --slopes -o '" +
                        (d / (input.stem().string() + ".ref.exr")).string() + "'")
                    .rc == 0);
    const auto ref_a = relief::test::file_pixels(d / "big.ref.exr"),
               ref_b = relief::test::file_pixels(d / "big_b.ref.exr");
    REQUIRE(ref_a != ref_b);
    for (int round = 0; round < 3; ++round) {
        INFO("round " << round);
        fs::remove(d / "out.exr");
        const std::string one = "unshare -p -f '" + std::string(RELIEF_CLI) + "' '";
        const std::string cmd = "cd '" + d.string() + "' && (" + one + a.string() +
                                "' --slopes -o out.exr & p=$!; " + one + b.string() +
                                "' --slopes -o out.exr & q=$!; wait $p && wait $q) 2>err.txt";
        CHECK(std::system(cmd.c_str()) == 0);
        INFO(slurp(d / "err.txt"));
        const auto got = relief::test::file_pixels(d / "out.exr");
        CHECK((got == ref_a || got == ref_b));
        CHECK(temporaries(d).empty());
    }
}

TEST_CASE(
    "output files: a job reading an earlier job's output runs in its shard, after it, and a later writer is "
    "refused",
    "[batch][files][cli][slow]")
{
    const auto d = relief::test::scratch("output_files/chains");
    {
        std::ofstream m(d / "jobs.txt");
        m << "'" << kSampleNormal << "' --height -o h.exr\n";         // job 0
        m << "'" << kSampleNormal << "' --slopes -o s.exr\n";         // job 1
        m << "'" << kSampleNormal << "' h.exr --preview -o p.png\n";  // job 2 reads job 0's output
        m << "'" << kSampleNormal << "' --slopes -o s3.exr\n";        // job 3
    }
    const auto jobs_of = [&](const std::string& shard) {
        auto r = run_cli("--batch jobs.txt --dry-run --shard " + shard, "cd '" + d.string() + "' &&");
        INFO(r.err);
        CHECK(r.rc == 0);
        std::vector<int> jobs;
        for (std::size_t at = 0; (at = r.out.find("{\"job\":", at)) != std::string::npos; at += 7)
            jobs.push_back(std::stoi(r.out.substr(at + 7)));
        return jobs;
    };
    CHECK(jobs_of("0/3") == std::vector<int>{0, 2, 3});
    CHECK(jobs_of("1/3") == std::vector<int>{1});
    CHECK(jobs_of("2/3").empty());
    // Run for real, shard by shard, the reader's shard first: the chain
    // still runs in order, in one process.
    for (const char* shard : {"2/3", "1/3", "0/3"})
        CHECK(run_cli("--batch jobs.txt --shard " + std::string(shard), "cd '" + d.string() + "' &&").rc ==
              0);
    CHECK(fs::exists(d / "p.png"));
    // The reader before its writer would read a stale file: refused.
    {
        std::ofstream m(d / "reversed.txt");
        m << "'" << kSampleNormal << "' h.exr --preview -o p.png\n";
        m << "'" << kSampleNormal << "' --height -o h.exr\n";
    }
    auto r = run_cli("--batch reversed.txt", "cd '" + d.string() + "' &&");
    CHECK(r.rc == 2);
    CHECK(r.err.find(
              "is the output of a later job, an -o output of job 1 (line 2): the reader would read a stale "
              "file; put the writer first") != std::string::npos);
}

TEST_CASE(
    "output files: --mesh estimates its memory and is refused under RELIEF_MEMORY_LIMIT before building",
    "[files][cli][mesh][slow]")
{
    const fs::path d = relief::test::scratch("output_files/mesh_memory");
    const std::string h = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/height.png";
    // 512^2 at patch=2:error=1e-6: about a million vertices, 0.35 GB at its
    // peak (measured 466 MB of RSS with the process's own).
    const auto t0 = std::chrono::steady_clock::now();
    auto r = run_cli("'" + h + "' --mesh:patch=2:error=1e-6:out='" + (d / "m.ply").string() + "'",
                     "RELIEF_MEMORY_LIMIT=200M");
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    INFO(r.err);
    CHECK(r.rc == 1);
    CHECK(r.err.find("triangles at the patches' first levels) needs") != std::string::npos);
    CHECK(r.err.find("of memory, RELIEF_MEMORY_LIMIT=") != std::string::npos);
    CHECK(seconds < 20.0);  // refused before building (the build takes minutes)
    CHECK_FALSE(fs::exists(d / "m.ply"));
    // A glTF holds its bytes in memory too: refused at a higher limit.
    r = run_cli("'" + h + "' --mesh:patch=2:error=1e-6:out='" + (d / "m.glb").string() + "'",
                "RELIEF_MEMORY_LIMIT=400M");
    CHECK(r.rc == 1);
    CHECK(r.err.find("RELIEF_MEMORY_LIMIT") != std::string::npos);
    // The default error fits easily.
    r = run_cli("'" + h + "' --mesh:out='" + (d / "m.ply").string() + "'", "RELIEF_MEMORY_LIMIT=200M");
    CHECK(r.rc == 0);
    CHECK(fs::exists(d / "m.ply"));
}
