// SPDX-License-Identifier: Apache-2.0
#pragma once
// Files that cannot clobber each other: before any work, every file a run
// writes is compared with every file it reads and every other file it
// writes, by identity (device and inode where the file exists, the
// normalised absolute path otherwise, so "a/../h.exr" and a hard link are
// the same file).
#include <string>
#include <vector>

#include "batch.h"
#include "command_line.h"

namespace relief::cli {

struct FileUse {
    // Input: an image the command line reads; Read: a file an operation reads
    // (mask=, fix=, env=).
    enum class Role { Manifest, Input, Read, Image, Written, Report, Log };
    std::string path;
    Role role;
    int job = -1;         // -1: the run's own (its manifest, its --log)
    int line = 0;         // the job's manifest line; 0 on a command line
    bool update = false;  // the job runs with --update
};

// The files job `prog` (number `job`, from manifest line `line`) reads and
// writes: inputs, masks, fix maps and environments; -o images, meshes and
// its --report.
void add_file_uses(const Program& prog, int job, int line, std::vector<FileUse>& uses);

// Whether `a` and `b` name one file: by identity where it exists (device
// and inode: hard links, "x/../a"), by normalised absolute path otherwise.
bool same_file(const std::string& a, const std::string& b);

// One job's -o output read by another, later job.
struct Dependency {
    int writer = 0, reader = 0;  // job indices, writer < reader
};

// Throws UsageError, naming both uses, when
//  - a --log, --report or mesh file would replace any file the run reads
//    (an input, the manifest) or writes;
//  - an image would replace the manifest, any other output, or a file an
//    operation of its own job reads (mask=, fix=, env=);
//  - an image would replace its own job's input under --update (the job
//    would never be up to date).
//  - a job reads the -o output of a later job (it would read a stale file).
// An image written over its own job's input stays allowed, as in oiiotool:
// the input is read in full first. Returns the jobs that read an earlier
// job's output: they must run after it, in its process (see chain_shards).
std::vector<Dependency> check_file_uses(const std::vector<FileUse>& uses);

// Gives each job of a chain (jobs linked by reading each other's outputs)
// the shard key of the chain's first job, so that --shard keeps a chain in
// one process, in file order.
void chain_shards(std::vector<Job>& jobs, const std::vector<Dependency>& dependencies);

}  // namespace relief::cli
