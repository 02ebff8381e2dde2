// SPDX-License-Identifier: Apache-2.0
// The relief process itself: how long it took to start, how it exits, what
// a termination signal does to the files it is writing.
#include "process.h"

#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "relief/output_files.h"

namespace relief::cli {

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

// Ends the process without the libraries' teardown (OpenCL contexts and
// PoCL's threads, OpenImageIO's caches): about 0.02 s a farm would pay per
// map for nothing, since every output is closed, synced and renamed by now.
// Sanitizer builds exit normally, so that their leak checks run.
void leave(int status)
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
namespace {

extern "C" void on_termination(int signal)
{
    relief::remove_temporary_files();
    ::_exit(128 + signal);
}

}  // namespace

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

}  // namespace relief::cli
