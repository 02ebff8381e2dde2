// SPDX-License-Identifier: Apache-2.0
// relief: the command line. Reads arguments left to right over a stack of
// images (oiiotool style); see `relief --help`. This file only dispatches:
// the stack runner (stack_runner.h) runs one command line's steps, the job
// runner (job_runner.h) command lines as jobs, one or a --batch file's.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "batch.h"
#include "command_line.h"
#include "console.h"
#include "job_log.h"
#include "job_runner.h"
#include "process.h"
#include "stack_runner.h"
#include "relief/relief.h"

namespace {

using relief::cli::Program;
using relief::cli::RunError;
using relief::cli::say;

int list_devices()
{
    auto devices = relief::list_devices();
    if (devices.empty())
        throw RunError(relief::geterror());
    for (const auto& d : devices)
        std::printf("%s  %s / %s%s%s\n", d.id.c_str(), d.platform.c_str(), d.name.c_str(),
                    d.is_gpu ? "  [GPU]" : "", d.has_fp64 ? "  fp64" : "");
    return 0;
}

int run(int argc, char** argv)
{
    const double age = relief::cli::process_age();
    const std::vector<std::string> args(argv + 1, argv + argc);
    Program prog;
    std::vector<relief::cli::Expansion> expanded;
    try {
        expanded = relief::cli::expand_names_with_tiles(args);
        // With several tiles or frames, each is checked as a job of its own
        // (a missing one fails alone); here only the options count.
        prog = relief::cli::parse_command_line(expanded.front().args, expanded.size() == 1);
    } catch (const relief::cli::UsageError& e) {
        say("relief: error: %s\n", e.what());
        relief::cli::log_refused_command_line(args, e.what());
        return 2;
    }
    if (prog.help) {
        std::fputs(
            (prog.help_markdown ? relief::cli::operations_markdown() : relief::cli::usage_text()).c_str(),
            stdout);
        return 0;
    }
    if (prog.version) {
        // The first line is the version (help2man, scripts); then what it
        // runs on: the libraries and each OpenCL platform.
        std::printf("relief %s\n", relief::version());
        for (const std::string& line : relief::component_versions())
            std::printf("  %s\n", line.c_str());
        return 0;
    }
    if (const std::string why = relief::environment_problem(); !why.empty()) {
        say("relief: error: %s\n", why.c_str());
        relief::cli::log_refused_command_line(args, why);
        return 2;
    }
    if (prog.verbose && age >= 0)
        say("relief: process start (loading libraries, before main): %.2f s\n", age);
    // The image libraries' own lines ("libpng error: ...") only with -v:
    // relief says why a file failed itself, once.
    if (prog.verbose)
        relief::set_library_messages([](relief::Severity, const std::string& line) {
            say("relief: (image library) %s\n", line.c_str());
        });
    try {
        if (prog.list_devices)
            return list_devices();
        if (!prog.batch.empty())
            return run_jobs(prog, relief::cli::read_jobs(prog.batch), prog.batch);
        if (prog.steps.empty()) {
            relief::cli::say_text(relief::cli::usage_text());
            return 2;
        }
        if (expanded.size() > 1 || expanded.front().args != args || prog.dry_run)
            // Tiles and frames: a batch of whole command lines (a UDIM set
            // whose --height joins its tiles is one job).
            return run_jobs(prog, relief::cli::jobs_of(expanded, {}, 0), "");
        relief::cli::run_command_line(prog, args);
        if (prog.verbose)
            say("relief: done %.2f s after the process started (then its exit)\n",
                relief::cli::process_age());
    } catch (const relief::cli::UsageError& e) {  // the --batch file's own syntax, a clobbered file
        say("relief: error: %s\n", e.what());
        if (!prog.batch.empty() || expanded.size() > 1)
            relief::cli::log_refused_command_line(args, e.what());
        return 2;
    } catch (const std::exception& e) {
        say("relief: error: %s\n", e.what());
        return 1;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv)
{
    relief::cli::open_console();
    relief::cli::remove_temporary_files_on_termination();
    relief::cli::leave(run(argc, argv));
}
