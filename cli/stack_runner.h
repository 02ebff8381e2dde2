// SPDX-License-Identifier: Apache-2.0
#pragma once
// Running one command line's steps, left to right over a stack of images as
// oiiotool does: a read pushes, an operation pops its inputs and pushes its
// result, -o writes the top; the --report file is written at the end.
#include <stdexcept>
#include <string>
#include <vector>

#include "command_line.h"

namespace relief::cli {

// A failure while running (a file, the device, an operation): exit status 1,
// where a UsageError is 2.
struct RunError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Runs `prog`'s steps. `digest` is the job's (job_digest.h): the k-th file
// written records output_digest(digest, k), "" none. Throws RunError.
void run_steps(const Program& prog, const std::string& digest);

// Runs the programs of a UDIM set's tiles (numbered `numbers`) as one job:
// step by step over all tiles, an operation that joins tiles
// (relief::joins_tiles) taking them all at once. Their outputs are numbered
// tile after tile under `digest`. Throws RunError.
void run_tile_steps(const std::vector<Program>& tiles, const std::vector<int>& numbers,
                    const std::string& digest);

}  // namespace relief::cli
