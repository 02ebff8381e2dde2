#include "batch.h"

#include <charconv>
#include <cstdio>
#include <fstream>

#include "command_line.h"

namespace relief::cli {

std::vector<std::string> split_words(const std::string& line)
{
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
        job.index = int(jobs.size());
        job.line = line;
        jobs.push_back(std::move(job));
    }
    if (in.bad())
        throw UsageError("--batch " + path + ": read error");
    return jobs;
}

std::pair<int, int> parse_shard(const std::string& text)
{
    const std::size_t slash = text.find('/');
    int i = -1, n = 0;
    const char* end = text.data() + text.size();
    const bool ok = slash != std::string::npos &&
                    std::from_chars(text.data(), text.data() + slash, i).ptr == text.data() + slash &&
                    slash + 1 < text.size() &&
                    std::from_chars(text.data() + slash + 1, end, n).ptr == end;
    if (!ok || n < 1 || i < 0 || i >= n)
        throw UsageError("--shard " + text + ": write I/N with 0 <= I < N (e.g. 0/4)");
    return {i, n};
}

std::vector<Job> shard_of(const std::vector<Job>& jobs, int index, int count)
{
    std::vector<Job> mine;
    for (const Job& j : jobs)
        if (j.index % count == index)
            mine.push_back(j);
    return mine;
}

std::string json_quote(const std::string& s)
{
    std::string out = "\"";
    for (const char ch : s) {
        const unsigned char u = static_cast<unsigned char>(ch);
        if (ch == '"' || ch == '\\') {
            out += '\\';
            out += ch;
        } else if (u < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", u);
            out += buf;
        } else {
            out += ch;
        }
    }
    return out + "\"";
}

} // namespace relief::cli
