// SPDX-License-Identifier: Apache-2.0
#pragma once
// The --log file: one JSON line per job (what it read and wrote, how it
// ended, when and where), appended whole as each job ends.
#include <string>
#include <vector>

namespace relief::cli {

// What one job did, for stderr and the --log line.
struct JobRecord {
    int index = 0, line = 0;
    std::vector<std::string> args;
    std::vector<std::string> inputs, outputs;
    std::string status = "failed";
    double seconds = 0.0;
    std::string message;
};

// The record as its --log line (no newline).
std::string json_line(const JobRecord& r);

// The --log file: opened for appending (O_APPEND), and each line written
// by one write(2): batches that share a log (shards of one farm) add whole
// lines, never tear or overwrite another's; a killed process leaves the
// lines of the jobs it finished. An empty path: no log. Throws RunError.
class JobLog {
public:
    explicit JobLog(const std::string& path);
    ~JobLog();
    JobLog(const JobLog&) = delete;
    JobLog& operator=(const JobLog&) = delete;
    void add(const JobRecord& r);

private:
    std::string path_;
    int fd_ = -1;
};

// A command line refused before it could run (`why`: a bad option or
// modifier, a missing input): its failed record in the --log file the
// arguments name, if they name one it could write and no other file of the
// line, so that every run with --log leaves a record. Never throws (a log
// it cannot write is warned of).
void log_refused_command_line(const std::vector<std::string>& args, const std::string& why);

}  // namespace relief::cli
