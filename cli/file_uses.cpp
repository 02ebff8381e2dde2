// SPDX-License-Identifier: Apache-2.0
#include "file_uses.h"

#include <filesystem>
#include <functional>
#include <map>
#include <system_error>
#include <tuple>

#include <sys/stat.h>

namespace relief::cli {

namespace fs = std::filesystem;

namespace {

using Role = FileUse::Role;

// What a file is, whatever the path that names it.
struct Identity {
    bool exists = false;
    dev_t device = 0;
    ino_t inode = 0;
    std::string path;
    bool operator<(const Identity& o) const
    {
        return std::tie(exists, device, inode, path) < std::tie(o.exists, o.device, o.inode, o.path);
    }
};

Identity identity_of(const std::string& path)
{
    Identity id;
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) {
        id.exists = true;
        id.device = st.st_dev;
        id.inode = st.st_ino;
        return id;
    }
    std::error_code ec;
    const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
    id.path = (ec ? fs::absolute(path, ec).lexically_normal() : p).string();
    return id;
}

bool writes(Role r)
{
    return r == Role::Image || r == Role::Written || r == Role::Report || r == Role::Log;
}

std::string describe(const FileUse& u)
{
    std::string what;
    switch (u.role) {
    case Role::Manifest: return "the --batch file";
    case Role::Log: return "the --log file";
    case Role::Input: what = "an input"; break;
    case Role::Read: what = "a file an operation reads (mask=, fix=, env=)"; break;
    case Role::Image: what = "an -o output"; break;
    case Role::Written: what = "an operation's output file (out=)"; break;
    case Role::Report: what = "the --report file"; break;
    }
    if (u.line > 0)
        what += " of job " + std::to_string(u.job) + " (line " + std::to_string(u.line) + ")";
    else if (u.job > 0)
        what += " of job " + std::to_string(u.job);
    return what;
}

// Why `a` and `b`, one file, cannot both be: "" when they can.
std::string conflict(const FileUse& a, const FileUse& b)
{
    const bool wa = writes(a.role), wb = writes(b.role);
    if (!wa && !wb)
        return "";
    const FileUse& w = wa ? a : b;
    const FileUse& r = wa ? b : a;
    if (wa && wb)
        return "it is both " + describe(a) + " and " + describe(b) + "; one would replace the other";
    if (w.role != Role::Image || r.role == Role::Manifest)
        return describe(w) + " would replace " + describe(r);
    // An image over an input: oiiotool's in-place edit, within one job;
    // across jobs, a chain (see check_file_uses).
    if (r.job != w.job)
        return r.job < w.job ? describe(r) + " is the output of a later job, " + describe(w) +
                                   ": the reader would read a stale file; put the writer first"
                             : "";
    // A mask or map is no image being edited: writing over it is a slip.
    if (r.role == Role::Read)
        return describe(w) + " would replace " + describe(r) + " of the same command line";
    if (w.update)
        return describe(w) + " is also its input: under --update the job would never be up to date";
    return "";
}

}  // namespace

bool same_file(const std::string& a, const std::string& b)
{
    const Identity x = identity_of(a), y = identity_of(b);
    return !(x < y) && !(y < x);
}

void add_file_uses(const Program& prog, int job, int line, std::vector<FileUse>& uses)
{
    const auto add = [&](const std::string& path, Role role) {
        if (!path.empty())
            uses.push_back({path, role, job, line, prog.update});
    };
    for (const Step& s : prog.steps) {
        if (s.kind == Step::Kind::Read)
            add(s.path, Role::Input);
        if (s.kind == Step::Kind::Operation) {
            for (const std::string& f : relief::files_read(s))
                add(f, Role::Read);
            for (const std::string& f : relief::files_written(s))
                add(f, Role::Written);
        }
        if (s.kind == Step::Kind::Write)
            add(s.path, Role::Image);
    }
    add(prog.report, Role::Report);
}

std::vector<Dependency> check_file_uses(const std::vector<FileUse>& uses)
{
    std::vector<Dependency> chains;
    std::map<Identity, std::vector<const FileUse*>> by_file;
    for (const FileUse& u : uses)
        by_file[identity_of(u.path)].push_back(&u);
    for (const auto& [id, same] : by_file) {
        if (same.size() < 2)
            continue;
        for (std::size_t i = 0; i < same.size(); ++i)
            for (std::size_t j = i + 1; j < same.size(); ++j)
                if (const std::string why = conflict(*same[i], *same[j]); !why.empty()) {
                    const std::string a = same[i]->path, b = same[j]->path;
                    throw UsageError("'" + a + "'" + (a == b ? "" : " and '" + b + "' are one file") + ": " +
                                     why + "; nothing was run");
                } else if (same[i]->job != same[j]->job && writes(same[i]->role) != writes(same[j]->role)) {
                    const FileUse& w = writes(same[i]->role) ? *same[i] : *same[j];
                    const FileUse& r = writes(same[i]->role) ? *same[j] : *same[i];
                    chains.push_back({w.job, r.job});
                }
    }
    return chains;
}

void chain_shards(std::vector<Job>& jobs, const std::vector<Dependency>& dependencies)
{
    // Union-find over job indices; a chain's key is its smallest index.
    std::map<int, int> parent;
    const std::function<int(int)> root = [&](int j) {
        auto it = parent.find(j);
        if (it == parent.end() || it->second == j)
            return j;
        return it->second = root(it->second);
    };
    for (const Dependency& d : dependencies) {
        const int a = root(d.writer), b = root(d.reader);
        if (a != b)
            parent[std::max(a, b)] = std::min(a, b);
    }
    for (Job& j : jobs)
        j.shard_key = root(j.index);
}

}  // namespace relief::cli
