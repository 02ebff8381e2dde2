// SPDX-License-Identifier: Apache-2.0
#pragma once
// Running one command line's steps, left to right over a stack of images as
// oiiotool does: a read pushes, an operation pops its inputs and pushes its
// result, -o writes the top; the --report file is written at the end.
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "command_line.h"
#include "read_ahead.h"

namespace relief::cli {

// A failure while running (a file, the device, an operation): exit status 1,
// where a UsageError is 2.
struct RunError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// How a job of a batch overlaps its neighbours (job_runner.cpp).
struct JobOverlap {
    ReadAhead* ahead = nullptr;  // images read ahead for this job, taken at its reads
    // Return the trailing writes (the -o steps after the last other step,
    // and the --report file) instead of running them: the caller runs them
    // on another thread while the next job computes.
    bool defer_writes = false;
};

// What is left of a job: its deferred writes (throw RunError), or empty.
// It refers to the job's programs, which must outlive it.
using DeferredWrites = std::function<void()>;

// Runs `prog`'s steps. `digest` is the job's (job_digest.h): the k-th file
// written records output_digest(digest, k), "" none. Throws RunError.
DeferredWrites run_steps(const Program& prog, const std::string& digest, const JobOverlap& overlap = {});

// Runs the programs of a UDIM set's tiles (numbered `numbers`) as one job:
// step by step over all tiles, an operation that joins tiles
// (relief::joins_tiles) taking them all at once. Their outputs are numbered
// tile after tile under `digest`. Throws RunError.
DeferredWrites run_tile_steps(const std::vector<Program>& tiles, const std::vector<int>& numbers,
                              const std::string& digest, const JobOverlap& overlap = {});

// The index of the first of the trailing write steps (steps.size() if the
// last step is not a write).
std::size_t trailing_writes(const std::vector<Step>& steps);

}  // namespace relief::cli
