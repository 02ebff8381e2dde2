// SPDX-License-Identifier: Apache-2.0
#pragma once
// Parses relief's oiiotool-like command line into a program of steps.
// Everything is validated before anything runs, so a typo in the last
// argument does not cost a long computation.
#include <OpenImageIO/typedesc.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "relief/errors.h"
#include "relief/imageio.h"
#include "relief/operations.h"

namespace relief::cli {

struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// One argument's work. Operations (--slopes, --height, ...) are the
// operation table's: `operation` names one, and its options are parsed into
// the OperationCall this derives from.
struct Step : OperationCall {
    enum class Kind { Read, Operation, Write, Dup } kind;  // Dup: --dup, push a copy of the top
    std::string text;                                      // the argument as typed, for messages
    std::string path;                                      // Read, Write
    OIIO::TypeDesc format;                                 // Write
    bool format_given = false;  // Write: -d was given (else baked textures keep their type)
    std::string compression;    // Write; empty = relief's default
};

struct Program {
    std::vector<Step> steps;
    std::string device = "auto";
    std::string report;  // --report FILE.json: the --height and --correct steps' reports
    bool verbose = false;
    bool help = false;
    bool help_markdown = false;  // --help:format=markdown
    bool version = false;
    bool list_devices = false;
    std::string batch;                     // --batch JOBS.txt: run the file's jobs instead of steps
    std::string log;                       // --log FILE.jsonl: one JSON object per job
    int shard_index = 0, shard_count = 1;  // --shard I/N (with --batch)
    bool update = false;                   // --update: skip a job whose outputs carry its relief:digest
    bool dry_run = false;  // --dry-run: list the jobs (and what --update would skip), run none
    std::string label;     // set by --batch: "job 3: ", before each message
};

// --shard I/N: "I/N" -> (I, N) with 0 <= I < N. Throws UsageError.
std::pair<int, int> parse_shard(const std::string& text);

// Throws UsageError with a one-line explanation. `check_inputs` false: an
// input file need not exist yet (the options of a command line whose tiles
// or frames are each parsed, and checked, as jobs of their own).
Program parse_command_line(const std::vector<std::string>& args, bool check_inputs = true);

// --help:format=markdown: every operation and modifier of the table as
// Markdown (the reference at the end of docs/cli.md).
std::string operations_markdown();
// --help: the fixed options, then every operation and modifier of the table.
const std::string& usage_text();

}  // namespace relief::cli
