// SPDX-License-Identifier: Apache-2.0
#include "batch.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <system_error>

#include "command_line.h"
#include "relief/imageio.h"

namespace relief::cli {

std::vector<std::string> split_words(const std::string& line)
{
    // A NUL would cut a name short at the system call (PNG bytes once went
    // into "nul.exr" from `-o nul.exr<NUL>.png`).
    if (line.find('\0') != std::string::npos)
        throw UsageError("the line holds a NUL byte, which no file name can");
    std::vector<std::string> words;
    std::string word;
    bool in_word = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
        const char c = line[i];
        if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
            if (in_word)
                words.push_back(word);
            word.clear();
            in_word = false;
        } else if (c == '#' && !in_word) {
            break;
        } else if (c == '\'') {
            const std::size_t end = line.find('\'', i + 1);
            if (end == std::string::npos)
                throw UsageError("unterminated ' quote");
            word += line.substr(i + 1, end - i - 1);
            in_word = true;
            i = end;
        } else if (c == '"') {
            in_word = true;
            for (++i;; ++i) {
                if (i >= line.size())
                    throw UsageError("unterminated \" quote");
                if (line[i] == '"')
                    break;
                if (line[i] == '\\' && i + 1 < line.size() &&
                    std::string("\"\\$`").find(line[i + 1]) != std::string::npos)
                    ++i;
                word += line[i];
            }
        } else if (c == '\\') {
            if (i + 1 >= line.size())
                throw UsageError("a backslash ends the line (lines do not continue)");
            word += line[++i];
            in_word = true;
        } else {
            word += c;
            in_word = true;
        }
    }
    if (in_word)
        words.push_back(word);
    return words;
}

std::vector<Job> read_jobs(const std::string& path)
{
    if (std::string why = relief::input_file_problem(path); !why.empty() && why != "the file is empty")
        throw UsageError("--batch " + path + ": " + (why == "no such file" ? "cannot read it: " + why : why));
    std::ifstream in(path);
    if (!in)
        throw UsageError("--batch " + path + ": cannot read it");
    std::vector<Job> jobs;
    std::string text;
    for (int line = 1; std::getline(in, text); ++line) {
        Job job;
        try {
            job.args = split_words(text);
        } catch (const UsageError& e) {
            throw UsageError(path + ":" + std::to_string(line) + ": " + e.what());
        }
        if (job.args.empty())
            continue;
        job.line = line;
        std::vector<Expansion> expanded;
        try {
            expanded = expand_names_with_tiles(job.args);
        } catch (const UsageError& e) {
            job.error = e.what();
            expanded = {{job.args, 0, job.args}};
        }
        for (Job& j : jobs_of(expanded, job, int(jobs.size())))
            jobs.push_back(std::move(j));
    }
    if (in.bad())
        throw UsageError("--batch " + path + ": read error");
    return jobs;
}

std::vector<Job> jobs_of(const std::vector<Expansion>& expanded, const Job& base, int first_index)
{
    // Whether the line's tiles go together: the table says, per operation.
    // (A line that does not parse runs tile by tile, each job failing alone.)
    const auto joined = [](const Expansion& e) {
        if (e.tile == 0)
            return false;
        try {
            const Program p = parse_command_line(e.args, false);
            return std::any_of(p.steps.begin(), p.steps.end(), [](const Step& s) {
                return s.kind == Step::Kind::Operation && relief::joins_tiles(s);
            });
        } catch (const UsageError&) {
            return false;
        }
    };
    std::vector<Job> jobs;
    for (std::size_t i = 0; i < expanded.size();) {
        Job j = base;
        j.index = first_index + int(jobs.size());
        j.args = expanded[i].args;
        std::size_t next = i + 1;
        if (base.error.empty() && joined(expanded[i])) {
            // The tiles of one line and frame share their words before the tile went in.
            while (next < expanded.size() && expanded[next].tile != 0 &&
                   expanded[next].pattern == expanded[i].pattern)
                ++next;
            if (next - i > 1) {
                j.args = expanded[i].pattern;
                for (std::size_t k = i; k < next; ++k) {
                    j.tiles.push_back(expanded[k].tile);
                    j.tile_args.push_back(expanded[k].args);
                }
            }
        }
        jobs.push_back(std::move(j));
        i = next;
    }
    return jobs;
}

std::vector<Job> shard_of(const std::vector<Job>& jobs, int index, int count)
{
    std::vector<Job> mine;
    for (const Job& j : jobs)
        if ((j.shard_key >= 0 ? j.shard_key : j.index) % count == index)
            mine.push_back(j);
    return mine;
}

}  // namespace relief::cli
