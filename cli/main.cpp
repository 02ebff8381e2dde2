// relief: the command line. Reads arguments left to right over a stack of
// images (oiiotool style); see `relief --help`. This file only dispatches:
// the stack runner (stack_runner.h) runs one command line's steps, the job
// runner (job_runner.h) command lines as jobs, one or a --batch file's.
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "batch.h"
#include "command_line.h"
#include "job_runner.h"
#include "stack_runner.h"
#include "relief/relief.h"

namespace {

using relief::cli::Program;
using relief::cli::RunError;

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
        throw RunError(relief::geterror());
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
        relief::cli::run_command_line(prog, args);
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

// SIGTERM (a farm's scheduler), SIGINT (Ctrl-C), SIGHUP: the outputs being
// written are temporary files; remove them and exit 128 + the signal, as a
// shell reports a killed command. Files already renamed are whole.
extern "C" void on_termination(int signal)
{
    relief::remove_temporary_files();
    ::_exit(128 + signal);
}

void remove_temporary_files_on_termination()
{
    struct sigaction action {};
    action.sa_handler = on_termination;
    sigemptyset(&action.sa_mask);
    for (int s : {SIGTERM, SIGINT, SIGHUP}) {
        struct sigaction old {};
        // A signal the parent set to be ignored (nohup) stays ignored.
        if (::sigaction(s, nullptr, &old) == 0 && old.sa_handler != SIG_IGN)
            ::sigaction(s, &action, nullptr);
    }
}

} // namespace

int main(int argc, char** argv)
{
    remove_temporary_files_on_termination();
    leave(run(argc, argv));
}
