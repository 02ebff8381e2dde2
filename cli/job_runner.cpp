// SPDX-License-Identifier: Apache-2.0
// The job runner: command lines as jobs, one or a manifest's, with their
// --log records, --update skips and the checks that no file clobbers another.
#include "job_runner.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <future>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "console.h"
#include "file_uses.h"
#include "job_digest.h"
#include "job_log.h"
#include "read_ahead.h"
#include "stack_runner.h"
#include "relief/relief.h"

namespace relief::cli {

namespace {

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

// The files a job reads and writes, for its record.
void list_files(const std::vector<Program>& progs, JobRecord& rec)
{
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
}

// Runs one parsed job (one program, or one per tile of a set that `tiles`
// numbers); fills its record instead of throwing. Returns its deferred
// writes (overlap.defer_writes), whose outcome is the record's: "ok" until
// they fail.
DeferredWrites run_job(const std::vector<Program>& progs, const std::vector<int>& tiles, JobRecord& rec,
                       const JobOverlap& overlap = {})
{
    const auto t0 = std::chrono::steady_clock::now();
    const Program& prog = progs.front();
    list_files(progs, rec);
    DeferredWrites rest;
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
            rest = tiles.empty() ? run_steps(prog, digest, overlap)
                                 : run_tile_steps(progs, tiles, digest, overlap);
            rec.status = "ok";
        }
    } catch (const std::exception& e) {
        rec.message = e.what();
    }
    rec.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return rest;
}

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

// Starts reading job `next`'s images ahead (its read steps; not its mask
// or fixation files, read at their operation), or returns null: a job that
// reads an earlier job's output, or that does not parse (it fails in its
// turn, as it would have).
std::unique_ptr<ReadAhead> read_ahead(const Program& top, const Job& next, const std::string& manifest,
                                      const std::set<int>& readers)
{
    if (readers.count(next.index) || !next.error.empty())
        return nullptr;
    std::vector<std::string> paths;
    try {
        for (const Program& p : job_programs(top, next, manifest))
            for (const Step& s : p.steps)
                if (s.kind == Step::Kind::Read)
                    paths.push_back(s.path);
    } catch (const std::exception&) {
        return nullptr;
    }
    if (paths.empty())
        return nullptr;
    auto reads = std::make_unique<ReadAhead>();
    reads->start(std::move(paths));
    return reads;
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
    std::map<int, std::vector<int>> writers_of;
    for (const Dependency& c : chains) {
        readers.insert(c.reader);
        writers_of[c.reader].push_back(c.writer);
    }
    // A dry run's jobs that would run: a reader of one of their outputs
    // would run too (the real run rewrites what it reads), whatever the
    // output on disk records now.
    std::set<int> would_run;
    const std::vector<Job> jobs = shard_of(chained, top.shard_index, top.shard_count);
    JobLog log(top.dry_run ? std::string() : top.log);
    int ok = 0, skipped = 0, failed = 0, pending = 0;
    // A job's end: its lines on stderr, its --log record.
    auto report = [&](const JobRecord& rec) {
        const std::string where =
            manifest.empty() ? std::string("command line") : manifest + ":" + std::to_string(rec.line);
        if (rec.status == "failed") {
            ++failed;
            say("relief: job %d (%s): error: %s\n", rec.index, where.c_str(), rec.message.c_str());
        } else {
            ++(rec.status == "ok" ? ok : rec.status == "skipped" ? skipped : pending);
            if (top.verbose)
                say("relief: job %d (%s): %s, %.3f s\n", rec.index, where.c_str(), rec.status.c_str(),
                    rec.seconds);
        }
        if (top.dry_run) {
            std::printf("%s\n", json_line(rec).c_str());
            std::fflush(stdout);
        }
        log.add(rec);
    };
    // Jobs overlap (a real run of two or more): while the device works on
    // job k, job k+1's images are read and decoded on one thread and job
    // k-1's trailing outputs written on another. At most three jobs' images
    // are in memory at once: one read ahead, one at work, one being
    // written. Each job's lines come out together and in job order (held
    // back while the job before is still writing), and its record is
    // written once its outputs are. A job that reads an earlier job's
    // output waits for every write before it, and is not read ahead.
    const bool overlap = !top.dry_run && jobs.size() > 1;
    struct Behind {  // a job whose outputs are being written
        JobRecord rec;
        std::shared_ptr<std::vector<Program>> progs;  // what its writes refer to
        std::string messages;                         // what its writes said
        double seconds = 0.0;                         // the writes' own time
        std::future<void> writes;
    };
    std::optional<Behind> behind;
    double read_time = 0.0, read_wait = 0.0, write_time = 0.0, write_wait = 0.0;
    auto end_behind = [&] {
        if (!behind)
            return;
        const auto w0 = std::chrono::steady_clock::now();
        behind->writes.wait();
        write_wait += std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
        write_time += behind->seconds;
        say_text(behind->messages);
        const JobRecord rec = behind->rec;
        behind.reset();
        report(rec);
    };
    std::unique_ptr<ReadAhead> next_reads;
    for (std::size_t k = 0; k < jobs.size(); ++k) {
        const Job& job = jobs[k];
        const bool reader = readers.count(job.index) > 0;
        if (reader)
            end_behind();
        JobRecord rec;
        rec.index = job.index;
        rec.line = job.line;
        rec.args = job.args;
        rec.message = job.error;
        const std::unique_ptr<ReadAhead> reads = std::move(next_reads);
        auto progs = std::make_shared<std::vector<Program>>();
        DeferredWrites rest;
        std::string held;  // this job's lines while the job before it writes
        {
            std::optional<HeldMessages> hold;
            if (behind)
                hold.emplace(held);
            if (overlap && !top.update && k + 1 < jobs.size())
                next_reads = read_ahead(top, jobs[k + 1], manifest, readers);
            try {
                *progs = job_programs(top, job, manifest, !(top.dry_run && reader));
                rest = run_job(*progs, job.tiles, rec, {reads.get(), overlap});
            } catch (const UsageError& e) {
                rec.message = e.what();
            }
            if (top.dry_run && rec.status == "skipped" && reader)
                for (int w : writers_of[job.index])
                    if (would_run.count(w)) {
                        rec.status = "pending";
                        rec.message = "reads the output of job " + std::to_string(w) + ", which would run";
                        break;
                    }
            if (top.dry_run && rec.status == "pending")
                would_run.insert(job.index);
        }
        if (reads) {
            read_time += reads->read_seconds();
            read_wait += reads->wait_seconds();
        }
        end_behind();
        say_text(held);
        if (!rest) {
            report(rec);
            continue;
        }
        behind.emplace();
        behind->rec = rec;
        behind->progs = progs;
        Behind& b = *behind;
        b.writes = std::async(std::launch::async, [&b, rest = std::move(rest)] {
            HeldMessages hold(b.messages);
            const auto w0 = std::chrono::steady_clock::now();
            try {
                rest();
            } catch (const std::exception& e) {
                b.rec.status = "failed";
                b.rec.message = e.what();
            }
            b.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
            b.rec.seconds += b.seconds;
        });
    }
    end_behind();
    if (overlap && top.verbose) {
        const double files = read_time + write_time, waited = read_wait + write_wait;
        say("relief: overlap: %.3f s of reading ahead and %.3f s of writing behind, %.3f s of it (%.0f%%) "
            "beside the device's work (%.3f s waited for)\n",
            read_time, write_time, std::max(0.0, files - waited),
            files > 0.0 ? 100.0 * std::max(0.0, files - waited) / files : 0.0, waited);
    }
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    say("relief: %s%s: ", manifest.empty() ? "jobs" : "batch ", manifest.c_str());
    if (top.dry_run)
        say("%d pending, %d skipped, %d failed of %zu job(s) (dry run)", pending, skipped, failed,
            jobs.size());
    else
        say("%d ok, %d skipped, %d failed of %zu job(s)", ok, skipped, failed, jobs.size());
    if (top.shard_count > 1)
        say(" (shard %d/%d of %zu)", top.shard_index, top.shard_count, all.size());
    say(", %.2f s\n", sec);
    return failed ? 1 : 0;
}

void run_command_line(const Program& prog, const std::vector<std::string>& args)
{
    Job whole;
    whole.args = args;
    try {
        check_files(prog, {whole}, "");
    } catch (const UsageError& e) {
        log_refused_command_line(args, e.what());
        throw;
    }
    JobLog log(prog.log);
    JobRecord rec;
    rec.args = args;
    run_job({prog}, {}, rec);
    log.add(rec);
    if (rec.status == "failed")
        throw RunError(rec.message);
    if (rec.status == "skipped" && prog.verbose)
        say("relief: up to date (every output records this run's relief:digest)\n");
}

}  // namespace relief::cli
