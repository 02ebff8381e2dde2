// SPDX-License-Identifier: Apache-2.0
#pragma once
// relief:digest, what `--update` compares: one hash of everything that
// decides a job's outputs.
#include <string>
#include <vector>

#include "command_line.h"

namespace relief::cli {

// XXH3-128 (32 hex digits) over relief's implementation digest (version and
// kernel sources) and the job's steps in order: each read's file bytes, each
// operation with every modifier (defaults included) and the bytes of its
// mask/fix files, each write's pixel type and compression. Paths themselves
// do not count: moving a job's files keeps its digest. "" when an input
// cannot be read (the run itself then says why, as reading it fails).
std::string job_digest(const Program& prog);

// The digest of a UDIM set run as one job (a --height that joins tiles):
// each tile's job_digest with its tile number, in order, since a tile's
// result depends on every tile it was solved with and on where they lie.
// "" when a tile's is.
std::string tile_set_digest(const std::vector<Program>& tiles, const std::vector<int>& numbers);

// The files a job writes besides its report, in step order: -o images and
// the files operations write (mesh's out=). Output k records
// output_digest(job digest, k); a tile set's tiles number theirs in turn.
std::vector<std::string> output_files(const Program& prog);

// What the job's output number `output` (from 0, in the order of its -o
// steps) records: the job's digest and the output's place in the job, so
// that swapping two outputs' names makes both out of date. "" when `job` is.
std::string output_digest(const std::string& job, int output);

}  // namespace relief::cli
