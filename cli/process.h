// SPDX-License-Identifier: Apache-2.0
#pragma once
// The relief process itself (process.cpp).

namespace relief::cli {

// Seconds from the process's start to now, to 1/100 s; -1 when /proc cannot
// tell. At the top of main: what loading the libraries cost.
double process_age();

// Exits with `status` after flushing stdio, without the libraries' teardown
// (sanitizer builds exit normally, for their leak checks).
[[noreturn]] void leave(int status);

// SIGTERM, SIGINT, SIGHUP remove the temporary files being written and exit
// 128 + the signal; a signal the parent ignores (nohup) stays ignored.
void remove_temporary_files_on_termination();

}  // namespace relief::cli
