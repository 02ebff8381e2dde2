// SPDX-License-Identifier: Apache-2.0
#pragma once
// Batches: a manifest of jobs, one ordinary relief command line per line,
// run in one process (one device context, its programs and FFT plans
// shared), optionally one shard of them.
#include <string>
#include <vector>

#include "names.h"

namespace relief::cli {

struct Job {
    int index = 0;                  // among the manifest's jobs, from 0 (what --shard counts)
    int line = 0;                   // in the manifest, from 1
    std::vector<std::string> args;  // the line's words (names expanded, see expand_names)
    std::string error;              // why the line could not be expanded (the job fails alone)
    int shard_key = -1;             // what --shard counts when not `index`: a chain's first job
    // A UDIM set run as one job, because an operation takes its tiles at
    // once (relief::joins_tiles: --height's udim=joint|auto): the tile
    // numbers and each tile's words; `args` is then the line with <UDIM>.
    std::vector<int> tiles;
    std::vector<std::vector<std::string>> tile_args;
};

// Jobs of one line's expansions (`base` gives the line and error; indices
// from `first_index`): one job per list, except that the tiles of one line
// and frame make one job when an operation of the line joins them.
std::vector<Job> jobs_of(const std::vector<Expansion>& expanded, const Job& base, int first_index);

// Splits one line into words as a POSIX shell would, without any expansion:
// blanks separate words; '...' is literal; "..." keeps blanks and takes \"
// \\ \$ \` as escapes; a backslash outside quotes takes the next character
// literally; an unquoted # at the start of a word begins a comment. Throws
// UsageError for an unterminated quote or a trailing backslash.
std::vector<std::string> split_words(const std::string& line);

// The jobs of a manifest (blank and comment-only lines skipped), each line
// expanded into one job per tile and frame. Throws UsageError naming
// FILE:LINE for a line that cannot be split into words; a line whose names
// cannot be expanded becomes one job carrying the error.
std::vector<Job> read_jobs(const std::string& path);

// The jobs of shard I of N: those whose index (or shard_key, where set: a
// chain of jobs reading each other's outputs goes with its first job) is
// congruent to I mod N, in manifest order.
std::vector<Job> shard_of(const std::vector<Job>& jobs, int index, int count);

}  // namespace relief::cli
