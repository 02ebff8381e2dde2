// relief: the command line. Reads arguments left to right over a stack of
// images (oiiotool style); see `relief --help`.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "batch.h"
#include "command_line.h"
#include "job_digest.h"
#include "text_file.h"
#include "relief/relief.h"

namespace {

using relief::Severity;
using relief::cli::Program;
using relief::cli::Step;

struct RuntimeError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// While it lives (unless verbose), the image libraries' own diagnostics on
// stderr ("libpng error: ...", "OIIO DEBUG: ...") go to /dev/null: relief
// reports the failure itself, once. Reads and writes run on this thread.
class QuietLibraries {
public:
    explicit QuietLibraries(bool verbose)
    {
        if (verbose)
            return;
        std::fflush(stderr);
        saved_ = dup(2);
        const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
        if (saved_ >= 0 && null >= 0)
            dup2(null, 2);
        if (null >= 0)
            close(null);
    }
    ~QuietLibraries()
    {
        if (saved_ < 0)
            return;
        std::fflush(stderr);
        dup2(saved_, 2);
        close(saved_);
    }
    QuietLibraries(const QuietLibraries&) = delete;
    QuietLibraries& operator=(const QuietLibraries&) = delete;

private:
    int saved_ = -1;
};

class Runner {
public:
    // `digest`: the job's digest; output k records output_digest(digest, k).
    Runner(const Program& prog, std::string digest) : prog_(prog), digest_(std::move(digest)) {}

    void run()
    {
        const double prepared = relief::setup_times().prepared;
        prepare_ahead();
        for (const Step& s : prog_.steps) {
            const auto t0 = std::chrono::steady_clock::now();
            const relief::SetupTimes before = relief::setup_times();
            run_step(s);
            if (!prog_.verbose)
                continue;
            const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const relief::SetupTimes after = relief::setup_times();
            const double device = after.device - before.device, programs = after.programs - before.programs,
                         plans = after.plans - before.plans;
            if (s.kind == Step::Kind::Operation)
                std::fprintf(stderr,
                             "relief: %s%s: %.3f s (device set-up %.3f, kernel builds %.3f, FFT plans %.3f, "
                             "the map's own work %.3f)\n",
                             prog_.label.c_str(), s.text.c_str(), sec, device, programs, plans,
                             sec - device - programs - plans);
            else
                std::fprintf(stderr, "relief: %s%s: %.3f s\n", prog_.label.c_str(),
                             s.kind == Step::Kind::Read ? ("read " + s.path).c_str() : s.text.c_str(), sec);
        }
        if (!prog_.report.empty()) {
            // One object per reporting operation, in the order they ran.
            std::string json = "{";
            for (const auto& [key, object] : report_)
                json += std::string(json.size() > 1 ? ",\n" : "\n") + "  \"" + key + "\": " +
                        indented(object);
            relief::cli::write_text_atomically(prog_.report, json + "\n}\n", "the report");
        }
        if (prog_.verbose && ahead_.valid()) {
            ahead_.wait();
            std::fprintf(stderr, "relief: %sset up ahead, beside the read: %.3f s\n", prog_.label.c_str(),
                         relief::setup_times().prepared - prepared);
        }
    }

private:
    // A program that starts by reading a map and taking its Poisson height
    // (the default) sets up the device, kernels and FFT plans for that size
    // on a second thread while the map is read and decoded.
    void prepare_ahead()
    {
        const auto& st = prog_.steps;
        std::size_t first = 1;  // the first operation (a --dup before it changes nothing)
        while (first < st.size() && st[first].kind == Step::Kind::Dup)
            ++first;
        if (first >= st.size() || st[0].kind != Step::Kind::Read || st[first].kind != Step::Kind::Operation ||
            st[first].operation != "height" || st[first].height.method == relief::HeightMethod::Rays)
            return;
        int width = 0, height = 0;
        {
            // The size from the header (about a millisecond), quietly: a
            // damaged file is the read's to report.
            QuietLibraries quiet(prog_.verbose);
            if (auto in = OIIO::ImageInput::open(st[0].path)) {
                width = in->spec().width;
                height = in->spec().height;
            } else {
                OIIO::geterror();
                return;
            }
        }
        ahead_ = std::async(std::launch::async,
                            [device = prog_.device, width, height] { relief::prepare(device, width, height); });
    }

    void message(Severity s, const std::string& msg) const
    {
        if (s == Severity::Warning)
            std::fprintf(stderr, "relief: %swarning: %s\n", prog_.label.c_str(), msg.c_str());
        else if (s == Severity::Notice || prog_.verbose)
            std::fprintf(stderr, "relief: %s%s\n", prog_.label.c_str(), msg.c_str());
    }

    relief::Execution execution(const Step& s) const
    {
        relief::Execution e;
        e.device = prog_.device;
        e.on_message = [this](Severity sev, const std::string& m) { message(sev, m); };
        if (prog_.verbose) {
            auto next = std::make_shared<int>(10);
            std::string name = s.text.substr(0, s.text.find(':'));
            e.on_progress = [name, next](double f) {
                while (f * 100.0 >= *next && *next <= 100) {
                    std::fprintf(stderr, "relief: %s: %d%%\n", name.c_str(), *next);
                    *next += 10;
                }
            };
        }
        return e;
    }

    bool read(OIIO::ImageBuf& img, const std::string& path) const
    {
        QuietLibraries quiet(prog_.verbose);
        return relief::read_image(img, path);
    }

    OIIO::ImageBuf pop()
    {
        OIIO::ImageBuf top = std::move(stack_.back());
        stack_.pop_back();
        return top;
    }

    void run_step(const Step& s)
    {
        switch (s.kind) {
        case Step::Kind::Read: {
            OIIO::ImageBuf img;
            if (!read(img, s.path))
                throw RuntimeError(relief::geterror());
            if (prog_.verbose) {
                const auto& spec = img.spec();
                std::fprintf(stderr, "relief: read %s: %dx%d, %d channel(s), %s\n", s.path.c_str(),
                             spec.width, spec.height, spec.nchannels, img.nativespec().format.c_str());
            }
            stack_.push_back(std::move(img));
            break;
        }
        case Step::Kind::Operation: {
            const relief::OperationInfo& op = *relief::find_operation(s.operation);
            relief::OperationCall call = s;
            // Mask and fixation files are read here, quietly like every read.
            OIIO::ImageBuf mask, fix;
            if (!s.mask_file.empty()) {
                if (!read(mask, s.mask_file))
                    throw RuntimeError("mask: " + relief::geterror());
                call.height.mask = &mask;
            }
            if (!s.fix_file.empty()) {
                if (!read(fix, s.fix_file))
                    throw RuntimeError("fix: " + relief::geterror());
                call.correct.fix_mask = &fix;
            }
            if (s.operation == "mesh")
                call.mesh.digest = relief::cli::output_digest(digest_, outputs_++);
            call.correct.report = &correct_report_;
            // The round trip costs a pass: only when it is reported or shown.
            if (!prog_.report.empty() || prog_.verbose)
                call.height.report = &height_report_;
            if (prog_.verbose && s.operation == "height")
                message(Severity::Info, "height: " + relief::describe(call.height));
            // The inputs are the top of the stack, the first input deepest.
            std::vector<OIIO::ImageBuf> in(op.inputs.size());
            for (std::size_t i = in.size(); i-- > 0;)
                in[i] = pop();
            std::vector<const OIIO::ImageBuf*> inputs;
            for (const OIIO::ImageBuf& b : in)
                inputs.push_back(&b);
            OIIO::ImageBuf out;
            if (!relief::run_operation(out, call, inputs, execution(s)))
                throw RuntimeError(relief::geterror());
            if (s.operation == "correct")
                report_.emplace_back("correct", correct_report_.to_json());
            if (s.operation == "height" && call.height.report)
                report_.emplace_back("height", height_report_.to_json());
            stack_.push_back(std::move(out));
            break;
        }
        case Step::Kind::Dup: {
            OIIO::ImageBuf copy;
            if (!copy.copy(stack_.back()))
                throw RuntimeError("--dup: " + copy.geterror());
            stack_.push_back(std::move(copy));
            break;
        }
        case Step::Kind::Write: {
            relief::WriteOptions w;
            w.format = s.format;
            const OIIO::ImageBuf& top = stack_.back();
            // Without -d a baked texture keeps its file's pixel type.
            const std::string native = top.spec().get_string_attribute("relief:native_format");
            if (!s.format_given && !native.empty())
                w.format = OIIO::TypeDesc(native);
            if (w.format == OIIO::TypeDesc::HALF && top.spec().get_string_attribute("relief:method") == "correct" &&
                std::max(top.spec().width, top.spec().height) > 2048)
                std::fprintf(stderr, "relief: warning: %s: half offsets above 2048 texels are coarser than 1/8 texel; prefer float\n",
                             s.path.c_str());
            w.compression = s.compression;
            const std::string digest = relief::cli::output_digest(digest_, outputs_++);
            if (digest.empty())
                stack_.back().specmod().erase_attribute("relief:digest");
            else
                stack_.back().specmod().attribute("relief:digest", digest);
            // The integer mapping is needed to read the file back: always say it.
            w.on_message = [](Severity, const std::string& m) {
                std::fprintf(stderr, "relief: %s\n", m.c_str());
            };
            if (!relief::write_image(stack_.back(), s.path, w))
                throw RuntimeError(relief::geterror());
            if (prog_.verbose)
                std::fprintf(stderr, "relief: wrote %s\n", s.path.c_str());
            break;
        }
        }
    }

    // A JSON object's text indented one level (after its first line), without its last newline.
    static std::string indented(std::string object)
    {
        while (!object.empty() && object.back() == '\n')
            object.pop_back();
        std::string out;
        for (char c : object) {
            out += c;
            if (c == '\n')
                out += "  ";
        }
        return out;
    }

    const Program& prog_;
    const std::string digest_;
    relief::CorrectReport correct_report_;
    relief::HeightReport height_report_;
    // (operation, its report's JSON object) in the order they ran; --report
    // allows one --height and one --correct.
    std::vector<std::pair<std::string, std::string>> report_;
    int outputs_ = 0;          // outputs (-o images, --mesh files) written so far
    std::future<void> ahead_;  // prepare_ahead(); its destructor waits for it
    std::vector<OIIO::ImageBuf> stack_;
};

// What one job did, for stderr and the --log line.
struct JobRecord {
    int index = 0, line = 0;
    std::vector<std::string> args;
    std::vector<std::string> inputs, outputs;
    std::string status = "failed";
    double seconds = 0.0;
    std::string message;
};

std::string json_list(const std::vector<std::string>& v)
{
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i)
        s += (i ? ", " : "") + relief::cli::json_quote(v[i]);
    return s + "]";
}

std::string json_line(const JobRecord& r)
{
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "%.3f", r.seconds);
    return "{\"job\": " + std::to_string(r.index) + ", \"line\": " + std::to_string(r.line) +
           ", \"args\": " + json_list(r.args) + ", \"inputs\": " + json_list(r.inputs) +
           ", \"outputs\": " + json_list(r.outputs) + ", \"status\": \"" + r.status +
           "\", \"seconds\": " + seconds + ", \"message\": " + relief::cli::json_quote(r.message) + "}";
}

// The files a job writes besides its report, in step order: -o images and
// --mesh files. Output k records output_digest(job digest, k).
std::vector<std::string> output_files(const Program& prog)
{
    std::vector<std::string> v;
    for (const Step& s : prog.steps) {
        if (s.kind == Step::Kind::Write)
            v.push_back(s.path);
        if (s.kind == Step::Kind::Operation && s.operation == "mesh")
            v.push_back(s.mesh.out);
    }
    return v;
}

// Whether every output of the job exists and records the digest it would
// get from the job's `digest` (read from the headers only). A --report file
// records none; it must exist.
bool up_to_date(const Program& prog, const std::string& digest)
{
    if (digest.empty())
        return false;
    int output = 0;
    for (const std::string& path : output_files(prog))
        if (relief::recorded_digest(path) != relief::cli::output_digest(digest, output++))
            return false;
    std::error_code ec;
    return prog.report.empty() || std::filesystem::is_regular_file(prog.report, ec);
}

// Runs one parsed job; fills its record instead of throwing.
void run_job(const Program& prog, JobRecord& rec)
{
    const auto t0 = std::chrono::steady_clock::now();
    for (const Step& s : prog.steps) {
        if (s.kind == Step::Kind::Read)
            rec.inputs.push_back(s.path);
        if (!s.mask_file.empty())
            rec.inputs.push_back(s.mask_file);
        if (!s.fix_file.empty())
            rec.inputs.push_back(s.fix_file);
        if (s.kind == Step::Kind::Operation && !s.preview.env.empty())
            rec.inputs.push_back(s.preview.env);
    }
    rec.outputs = output_files(prog);
    if (!prog.report.empty())
        rec.outputs.push_back(prog.report);
    try {
        // A dry run without --update lists the jobs without reading their inputs.
        const std::string digest = prog.dry_run && !prog.update ? std::string() : relief::cli::job_digest(prog);
        if (prog.update && up_to_date(prog, digest)) {
            rec.status = "skipped";
            rec.message = "up to date";
        } else if (prog.dry_run) {
            rec.status = "pending";
        } else {
            Runner(prog, digest).run();
            rec.status = "ok";
        }
    } catch (const std::exception& e) {
        rec.message = e.what();
    }
    rec.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The --log file: one line per job, flushed as each job ends, so a killed
// process leaves the lines of the jobs it finished.
class JobLog {
public:
    explicit JobLog(const std::string& path) : path_(path)
    {
        if (path.empty())
            return;
        file_ = std::fopen(path.c_str(), "w");
        if (!file_)
            throw RuntimeError("--log " + path + ": cannot write it");
    }
    ~JobLog()
    {
        if (file_)
            std::fclose(file_);
    }
    JobLog(const JobLog&) = delete;
    JobLog& operator=(const JobLog&) = delete;
    void add(const JobRecord& r)
    {
        if (!file_)
            return;
        const std::string line = json_line(r) + "\n";
        if (std::fputs(line.c_str(), file_) < 0 || std::fflush(file_) != 0)
            throw RuntimeError("--log " + path_ + ": write failed");
    }

private:
    std::string path_;
    std::FILE* file_ = nullptr;
};

// Jobs in this process, one after the other, sharing the device context and
// its caches: a --batch file's (`manifest` names it; the batch's -v,
// --device, --update and --dry-run apply to every job, a job's own come
// later and win) or a command line's tiles and frames (`manifest` empty:
// each job is a whole command line). Only this process's --shard runs.
// Returns the exit status.
int run_jobs(const Program& top, const std::vector<relief::cli::Job>& all, const std::string& manifest)
{
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<relief::cli::Job> jobs = relief::cli::shard_of(all, top.shard_index, top.shard_count);
    JobLog log(top.dry_run ? std::string() : top.log);
    int ok = 0, skipped = 0, failed = 0, pending = 0;
    for (const relief::cli::Job& job : jobs) {
        JobRecord rec;
        rec.index = job.index;
        rec.line = job.line;
        rec.args = job.args;
        rec.message = job.error;
        try {
            if (!job.error.empty())
                throw relief::cli::UsageError(job.error);
            std::vector<std::string> args;
            if (!manifest.empty()) {
                args = {"--device", top.device};
                for (const auto& [on, flag] : {std::pair{top.verbose, "-v"}, std::pair{top.update, "--update"},
                                               std::pair{top.dry_run, "--dry-run"}})
                    if (on)
                        args.push_back(flag);
            }
            args.insert(args.end(), job.args.begin(), job.args.end());
            Program p = relief::cli::parse_command_line(args);
            p.label = "job " + std::to_string(job.index) + ": ";
            if (!manifest.empty() &&
                (!p.batch.empty() || !p.log.empty() || p.help || p.version || p.list_devices || p.steps.empty()))
                throw relief::cli::UsageError("a job is images, operations and outputs (no --batch, --log, "
                                              "--help, --version or --list-devices)");
            run_job(p, rec);
        } catch (const relief::cli::UsageError& e) {
            rec.message = e.what();
        }
        const std::string where = manifest.empty() ? std::string("command line")
                                                   : manifest + ":" + std::to_string(job.line);
        if (rec.status == "failed") {
            ++failed;
            std::fprintf(stderr, "relief: job %d (%s): error: %s\n", job.index, where.c_str(), rec.message.c_str());
        } else {
            ++(rec.status == "ok" ? ok : rec.status == "skipped" ? skipped : pending);
            if (top.verbose)
                std::fprintf(stderr, "relief: job %d (%s): %s, %.3f s\n", job.index, where.c_str(),
                             rec.status.c_str(), rec.seconds);
        }
        if (top.dry_run) {
            std::printf("%s\n", json_line(rec).c_str());
            std::fflush(stdout);
        }
        log.add(rec);
    }
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "relief: %s%s: ", manifest.empty() ? "jobs" : "batch ", manifest.c_str());
    if (top.dry_run)
        std::fprintf(stderr, "%d pending, %d skipped, %d failed of %zu job(s) (dry run)", pending, skipped,
                     failed, jobs.size());
    else
        std::fprintf(stderr, "%d ok, %d skipped, %d failed of %zu job(s)", ok, skipped, failed, jobs.size());
    if (top.shard_count > 1)
        std::fprintf(stderr, " (shard %d/%d of %zu)", top.shard_index, top.shard_count, all.size());
    std::fprintf(stderr, ", %.2f s\n", sec);
    return failed ? 1 : 0;
}

// Seconds from the process's start to now (the kernel's clock ticks, so to
// 1/100 s): at the top of main, what loading the libraries cost.
double process_age()
{
    std::ifstream stat("/proc/self/stat"), uptime("/proc/uptime");
    std::string text;
    std::getline(stat, text);
    double up = -1.0;
    uptime >> up;
    const std::size_t paren = text.rfind(')');
    if (paren == std::string::npos || up < 0)
        return -1.0;
    std::istringstream fields(text.substr(paren + 2));
    std::string field;
    for (int i = 3; i <= 22 && fields >> field; ++i)  // field 22: starttime
        ;
    return up - std::atof(field.c_str()) / double(sysconf(_SC_CLK_TCK));
}

int list_devices()
{
    auto devices = relief::list_devices();
    if (devices.empty())
        throw RuntimeError(relief::geterror());
    for (const auto& d : devices)
        std::printf("%s  %s / %s%s%s\n", d.id.c_str(), d.platform.c_str(), d.name.c_str(),
                    d.is_gpu ? "  [GPU]" : "", d.has_fp64 ? "  fp64" : "");
    return 0;
}

int run(int argc, char** argv)
{
    const double age = process_age();
    const std::vector<std::string> args(argv + 1, argv + argc);
    Program prog;
    std::vector<std::vector<std::string>> expanded;
    try {
        expanded = relief::cli::expand_names(args);
        // With several tiles or frames, each is checked as a job of its own
        // (a missing one fails alone); here only the options count.
        prog = relief::cli::parse_command_line(expanded.front(), expanded.size() == 1);
    } catch (const relief::cli::UsageError& e) {
        std::fprintf(stderr, "relief: error: %s\n", e.what());
        return 2;
    }
    if (prog.help) {
        std::fputs(relief::cli::usage_text().c_str(), stdout);
        return 0;
    }
    if (prog.version) {
        std::printf("relief %s\n", relief::version());
        return 0;
    }
    if (prog.verbose && age >= 0)
        std::fprintf(stderr, "relief: process start (loading libraries, before main): %.2f s\n", age);
    try {
        if (prog.list_devices)
            return list_devices();
        if (!prog.batch.empty())
            return run_jobs(prog, relief::cli::read_jobs(prog.batch), prog.batch);
        if (prog.steps.empty()) {
            std::fputs(relief::cli::usage_text().c_str(), stderr);
            return 2;
        }
        if (expanded.size() > 1 || expanded.front() != args || prog.dry_run) {
            // Tiles and frames: a batch of whole command lines.
            std::vector<relief::cli::Job> jobs;
            for (const auto& a : expanded) {
                relief::cli::Job j;
                j.index = int(jobs.size());
                j.args = a;
                jobs.push_back(j);
            }
            return run_jobs(prog, jobs, "");
        }
        JobLog log(prog.log);
        JobRecord rec;
        rec.args = args;
        run_job(prog, rec);
        log.add(rec);
        if (rec.status == "failed")
            throw RuntimeError(rec.message);
        if (rec.status == "skipped" && prog.verbose)
            std::fprintf(stderr, "relief: up to date (every output records this run's relief:digest)\n");
        if (prog.verbose)
            std::fprintf(stderr, "relief: done %.2f s after the process started (then its exit)\n", process_age());
    } catch (const relief::cli::UsageError& e) {  // the --batch file's own syntax
        std::fprintf(stderr, "relief: error: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "relief: error: %s\n", e.what());
        return 1;
    }
    return 0;
}

// Ends the process without the libraries' teardown (OpenCL contexts and
// PoCL's threads, OpenImageIO's caches): about 0.02 s a farm would pay per
// map for nothing, since every output is closed, synced and renamed by now.
// Sanitizer builds exit normally, so that their leak checks run.
[[noreturn]] void leave(int status)
{
    std::fflush(nullptr);
#if defined(__SANITIZE_ADDRESS__)
    std::exit(status);
#else
    std::_Exit(status);
#endif
}

} // namespace

int main(int argc, char** argv)
{
    leave(run(argc, argv));
}
