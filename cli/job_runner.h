// SPDX-License-Identifier: Apache-2.0
#pragma once
// Command lines run as jobs: each with a --log record (one JSON line),
// skipped under --update when its outputs record its digest, listed under
// --dry-run; and, before any runs, the check that no job's write clobbers
// what the run reads or another of its writes (file_uses.h).
#include <string>
#include <vector>

#include "batch.h"
#include "command_line.h"

namespace relief::cli {

// Jobs in this process, one after the other, sharing the device context and
// its caches: a --batch file's (`manifest` names it; the batch's -v,
// --device, --update and --dry-run apply to every job, a job's own come
// later and win) or a command line's tiles and frames (`manifest` empty:
// each job is a whole command line). Only `top`'s --shard runs. Returns the
// exit status (1 when a job failed). Throws UsageError, RunError (the log).
int run_jobs(const Program& top, const std::vector<Job>& all, const std::string& manifest);

// One command line (`args`, parsed as `prog`) as one job. Throws UsageError
// (a clobbered file), RunError (the job failed: its message).
void run_command_line(const Program& prog, const std::vector<std::string>& args);

}  // namespace relief::cli
