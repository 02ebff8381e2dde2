// SPDX-License-Identifier: Apache-2.0
#include "job_log.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <system_error>

#include "command_line.h"
#include "console.h"
#include "file_uses.h"
#include "json_text.h"
#include "relief/output_files.h"
#include "stack_runner.h"

namespace relief::cli {

namespace {

// When a record is written, in UTC (ISO 8601, to the second): logs of
// many hosts and time zones sort as one.
std::string utc_now()
{
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
}

// The machine that ran the job (farms append many hosts' records to one log).
std::string host_name()
{
    char name[256] = {};
    if (gethostname(name, sizeof name - 1) != 0)
        return "";
    return name;
}

}  // namespace

std::string json_line(const JobRecord& r)
{
    Json line;
    line["job"] = r.index;
    line["line"] = r.line;
    line["args"] = json_bytes(r.args);
    line["inputs"] = json_bytes(r.inputs);
    line["outputs"] = json_bytes(r.outputs);
    line["status"] = r.status;
    line["seconds"] = std::round(r.seconds * 1000.0) / 1000.0;
    line["message"] = json_bytes(r.message);
    line["time"] = utc_now();
    line["host"] = json_bytes(host_name());
    return json_text(line);
}

JobLog::JobLog(const std::string& path) : path_(path)
{
    if (path.empty())
        return;
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0666);
    if (fd_ < 0)
        throw RunError("--log " + path + ": cannot write it: " + std::strerror(errno));
}

JobLog::~JobLog()
{
    if (fd_ >= 0)
        ::close(fd_);
}

void JobLog::add(const JobRecord& r)
{
    if (fd_ < 0)
        return;
    const std::string line = json_line(r) + "\n";
    ssize_t done;
    do
        done = ::write(fd_, line.data(), line.size());
    while (done < 0 && errno == EINTR);
    if (done != ssize_t(line.size()))
        throw RunError("--log " + path_ +
                       ": write failed: " + (done < 0 ? std::strerror(errno) : "the disk is full"));
}

namespace {

// Every word of `args` that may name a file, but --log's own: each
// argument, and each modifier's value (--op:key=value:...).
std::vector<std::string> named_files(const std::vector<std::string>& args)
{
    std::vector<std::string> out;
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (i > 0 && args[i - 1] == "--log")
            continue;
        out.push_back(a);
        if (a.rfind("--", 0) != 0)
            continue;
        for (std::size_t at = a.find(':'); at != std::string::npos; at = a.find(':', at + 1)) {
            const std::size_t eq = a.find('=', at), end = a.find(':', at + 1);
            if (eq != std::string::npos && eq < end)
                out.push_back(a.substr(eq + 1, end == std::string::npos ? std::string::npos : end - eq - 1));
        }
    }
    return out;
}

}  // namespace

void log_refused_command_line(const std::vector<std::string>& args, const std::string& why)
{
    std::string path;
    for (std::size_t i = 0; i + 1 < args.size(); ++i)
        if (args[i] == "--log")
            path = args[i + 1];
    if (std::find(args.begin(), args.end(), "--dry-run") != args.end())
        return;  // (a dry run writes no log)
    try {
        // Only where --log itself would have been taken (text_output's rule),
        // and never into a file the line names otherwise (the refusal may be
        // that very clash: --log onto the --batch file or an input).
        if (path.empty() || !relief::output_name_problem(path).empty() || std::filesystem::is_directory(path))
            return;
        for (const std::string& named : named_files(args))
            if (same_file(named, path))
                return;
        JobLog log(path);
        JobRecord rec;
        rec.args = args;
        rec.message = why;
        log.add(rec);
    } catch (const std::exception& e) {
        say("relief: warning: %s\n", e.what());
    }
}

}  // namespace relief::cli
