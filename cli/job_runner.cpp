// SPDX-License-Identifier: Apache-2.0
// The job runner: command lines as jobs, one or a manifest's, with their
// --log records, --update skips and the checks that no file clobbers another.
#include "job_runner.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <set>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "file_uses.h"
#include "job_digest.h"
#include "json_text.h"
#include "stack_runner.h"
#include "relief/relief.h"

namespace relief::cli {

namespace {

// What one job did, for stderr and the --log line.
struct JobRecord {
    int index = 0, line = 0;
    std::vector<std::string> args;
    std::vector<std::string> inputs, outputs;
    std::string status = "failed";
    double seconds = 0.0;
    std::string message;
};

// When a record is written, in UTC (ISO 8601, to the second): logs of
// many hosts and time zones sort as one.
std::string utc_now()
{
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
}

// The machine that ran the job (farms append many hosts' records to one log).
std::string host_name()
{
    char name[256] = {};
    if (gethostname(name, sizeof name - 1) != 0)
        return "";
    return name;
}

std::string json_line(const JobRecord& r)
{
    Json line;
    line["job"] = r.index;
    line["line"] = r.line;
    line["args"] = json_bytes(r.args);
    line["inputs"] = json_bytes(r.inputs);
    line["outputs"] = json_bytes(r.outputs);
    line["status"] = r.status;
    line["seconds"] = std::round(r.seconds * 1000.0) / 1000.0;
    line["message"] = json_bytes(r.message);
    line["time"] = utc_now();
    line["host"] = json_bytes(host_name());
    return json_text(line);
}

// Whether every output of the job (its programs: one, or a tile set's)
// exists and records the digest it would get from the job's `digest` (read
// from the headers only). A --report file records none; it must exist.
bool up_to_date(const std::vector<Program>& progs, const std::string& digest)
{
    if (digest.empty())
        return false;
    int output = 0;
    for (const Program& prog : progs) {
        for (const std::string& path : output_files(prog))
            if (relief::recorded_digest(path) != output_digest(digest, output++))
                return false;
        std::error_code ec;
        if (!prog.report.empty() && !std::filesystem::is_regular_file(prog.report, ec))
            return false;
    }
    return true;
}

// Runs one parsed job (one program, or one per tile of a set that `tiles`
// numbers); fills its record instead of throwing.
void run_job(const std::vector<Program>& progs, const std::vector<int>& tiles, JobRecord& rec)
{
    const auto t0 = std::chrono::steady_clock::now();
    const Program& prog = progs.front();
    for (const Program& p : progs) {
        for (const Step& s : p.steps) {
            if (s.kind == Step::Kind::Read)
                rec.inputs.push_back(s.path);
            if (s.kind == Step::Kind::Operation)
                for (const std::string& f : relief::files_read(s))
                    rec.inputs.push_back(f);
        }
        for (const std::string& f : output_files(p))
            rec.outputs.push_back(f);
        if (!p.report.empty())
            rec.outputs.push_back(p.report);
    }
    try {
        // A dry run without --update lists the jobs without reading their inputs.
        const std::string digest = prog.dry_run && !prog.update ? std::string()
                                   : tiles.empty()              ? job_digest(prog)
                                                                : tile_set_digest(progs, tiles);
        if (prog.update && up_to_date(progs, digest)) {
            rec.status = "skipped";
            rec.message = "up to date";
        } else if (prog.dry_run) {
            rec.status = "pending";
        } else {
            if (tiles.empty())
                run_steps(prog, digest);
            else
                run_tile_steps(progs, tiles, digest);
            rec.status = "ok";
        }
    } catch (const std::exception& e) {
        rec.message = e.what();
    }
    rec.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The --log file: one JSON line per job, appended as each job ends, so a
// killed process leaves the lines of the jobs it finished. Opened for
// appending and each line written by one write(2) under O_APPEND: batches
// that share a log (shards of one farm) add whole lines, never tear or
// overwrite another's.
class JobLog {
public:
    explicit JobLog(const std::string& path) : path_(path)
    {
        if (path.empty())
            return;
        fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0666);
        if (fd_ < 0)
            throw RunError("--log " + path + ": cannot write it: " + std::strerror(errno));
    }
    ~JobLog()
    {
        if (fd_ >= 0)
            ::close(fd_);
    }
    JobLog(const JobLog&) = delete;
    JobLog& operator=(const JobLog&) = delete;
    void add(const JobRecord& r)
    {
        if (fd_ < 0)
            return;
        const std::string line = json_line(r) + "\n";
        ssize_t done;
        do
            done = ::write(fd_, line.data(), line.size());
        while (done < 0 && errno == EINTR);
        if (done != ssize_t(line.size()))
            throw RunError("--log " + path_ +
                           ": write failed: " + (done < 0 ? std::strerror(errno) : "the disk is full"));
    }

private:
    std::string path_;
    int fd_ = -1;
};

// A job as it runs: a manifest's job gets the batch's -v, --device,
// --update and --dry-run first (its own come later and win). Throws
// UsageError.
Program job_program(const Program& top, const Job& job, const std::vector<std::string>& words,
                    const std::string& manifest, bool check_inputs)
{
    if (!job.error.empty())
        throw UsageError(job.error);
    std::vector<std::string> args;
    if (!manifest.empty()) {
        args = {"--device", top.device};
        for (const auto& [on, flag] : {std::pair{top.verbose, "-v"}, std::pair{top.update, "--update"},
                                       std::pair{top.dry_run, "--dry-run"}})
            if (on)
                args.push_back(flag);
    }
    args.insert(args.end(), words.begin(), words.end());
    Program p = parse_command_line(args, check_inputs);
    p.label = "job " + std::to_string(job.index) + ": ";
    if (!manifest.empty() &&
        (!p.batch.empty() || !p.log.empty() || p.help || p.version || p.list_devices || p.steps.empty()))
        throw UsageError("a job is images, operations and outputs (no --batch, --log, "
                         "--help, --version or --list-devices)");
    return p;
}

// The job's programs: its own, or one per tile of a set run as one job.
std::vector<Program> job_programs(const Program& top, const Job& job, const std::string& manifest,
                                  bool check_inputs = true)
{
    if (job.tiles.empty())
        return {job_program(top, job, job.args, manifest, check_inputs)};
    std::vector<Program> progs;
    for (std::size_t i = 0; i < job.tiles.size(); ++i) {
        progs.push_back(job_program(top, job, job.tile_args[i], manifest, check_inputs));
        progs.back().label += "tile " + std::to_string(job.tiles[i]) + ": ";
    }
    return progs;
}

// Refuses, before any work, a run whose writes would clobber what it reads
// or another of its writes (see file_uses.h): every job of the manifest
// counts, not only this shard's, since the shards run at once. A job that
// does not parse fails on its own later. Returns which jobs read an
// earlier job's output.
std::vector<Dependency> check_files(const Program& top, const std::vector<Job>& all,
                                    const std::string& manifest)
{
    std::vector<FileUse> uses;
    if (!manifest.empty())
        uses.push_back({manifest, FileUse::Role::Manifest});
    if (!top.log.empty() && !top.dry_run)
        uses.push_back({top.log, FileUse::Role::Log});
    for (const Job& job : all) {
        try {
            // An input may be an earlier job's output, not made yet.
            for (const Program& p : job_programs(top, job, manifest, false))
                add_file_uses(p, job.index, job.line, uses);
        } catch (const UsageError&) {
        }
    }
    return check_file_uses(uses);
}

}  // namespace

// Jobs in this process, one after the other, sharing the device context and
// its caches: a --batch file's (`manifest` names it; the batch's -v,
// --device, --update and --dry-run apply to every job, a job's own come
// later and win) or a command line's tiles and frames (`manifest` empty:
// each job is a whole command line). Only this process's --shard runs.
// Returns the exit status.
int run_jobs(const Program& top, const std::vector<Job>& all, const std::string& manifest)
{
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<Job> chained = all;
    const std::vector<Dependency> chains = check_files(top, all, manifest);
    chain_shards(chained, chains);
    // A dry run makes no files: a reader of an earlier job's output is
    // pending, not failed for want of it.
    std::set<int> readers;
    for (const Dependency& c : chains)
        readers.insert(c.reader);
    const std::vector<Job> jobs = shard_of(chained, top.shard_index, top.shard_count);
    JobLog log(top.dry_run ? std::string() : top.log);
    int ok = 0, skipped = 0, failed = 0, pending = 0;
    for (const Job& job : jobs) {
        JobRecord rec;
        rec.index = job.index;
        rec.line = job.line;
        rec.args = job.args;
        rec.message = job.error;
        try {
            run_job(job_programs(top, job, manifest, !(top.dry_run && readers.count(job.index))), job.tiles,
                    rec);
        } catch (const UsageError& e) {
            rec.message = e.what();
        }
        const std::string where =
            manifest.empty() ? std::string("command line") : manifest + ":" + std::to_string(job.line);
        if (rec.status == "failed") {
            ++failed;
            std::fprintf(stderr, "relief: job %d (%s): error: %s\n", job.index, where.c_str(),
                         rec.message.c_str());
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

void run_command_line(const Program& prog, const std::vector<std::string>& args)
{
    Job whole;
    whole.args = args;
    check_files(prog, {whole}, "");
    JobLog log(prog.log);
    JobRecord rec;
    rec.args = args;
    run_job({prog}, {}, rec);
    log.add(rec);
    if (rec.status == "failed")
        throw RunError(rec.message);
    if (rec.status == "skipped" && prog.verbose)
        std::fprintf(stderr, "relief: up to date (every output records this run's relief:digest)\n");
}

}  // namespace relief::cli
