#include "batch.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

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
        job.line = line;
        std::vector<std::vector<std::string>> expanded;
        try {
            expanded = expand_names(job.args);
        } catch (const UsageError& e) {
            job.error = e.what();
            expanded = {job.args};
        }
        for (auto& args : expanded) {
            Job j = job;
            j.args = std::move(args);
            j.index = int(jobs.size());
            jobs.push_back(std::move(j));
        }
    }
    if (in.bad())
        throw UsageError("--batch " + path + ": read error");
    return jobs;
}

namespace {

// "1-10,20,30-32" -> every frame, in the order given. Throws UsageError.
std::vector<int> parse_frames(const std::string& text)
{
    constexpr long long kLimit = 1000000000;  // |frame| <= 10^9: no overflow below
    std::vector<int> frames;
    const auto bad = [&text] {
        return UsageError("--frames " + text + ": write ranges like 1-10,20,30-32 (A <= B, |frames| <= 10^9, "
                          "at most 100000 frames)");
    };
    const auto number = [&](const char* from, const char* to) {
        long long v = 0;
        const auto r = std::from_chars(from, to, v);
        if (from == to || r.ptr != to || r.ec != std::errc() || v < -kLimit || v > kLimit)
            throw bad();
        return v;
    };
    for (std::size_t pos = 0; pos <= text.size();) {
        const std::size_t comma = std::min(text.find(',', pos), text.size());
        const std::string part = text.substr(pos, comma - pos);
        const std::size_t dash = part.empty() ? std::string::npos : part.find('-', 1);
        const char* begin = part.data();
        const char* end = begin + part.size();
        const char* mid = dash == std::string::npos ? end : begin + dash;
        const long long first = number(begin, mid);
        const long long last = dash == std::string::npos ? first : number(mid + 1, end);
        if (last < first || frames.size() + std::size_t(last - first) >= 100000)
            throw bad();
        for (long long f = first; f <= last; ++f)
            frames.push_back(int(f));
        pos = comma + 1;
    }
    return frames;
}

// The frame number in `width` digits (zero-padded). Throws UsageError past 32.
std::string padded_frame(int frame, std::size_t width)
{
    if (width > 32)
        throw UsageError("a frame token of " + std::to_string(width) + " digits (32 at most)");
    char buf[48];
    std::snprintf(buf, sizeof buf, "%0*d", int(width), frame);
    return buf;
}

// The frame tokens of `arg` replaced by `frame` (%% is a literal %); `found`
// says whether it had any.
std::string with_frame(const std::string& arg, int frame, bool& found)
{
    std::string out;
    for (std::size_t i = 0; i < arg.size();) {
        const char c = arg[i];
        if (c == '#' || c == '@') {
            std::size_t n = 0;
            while (i + n < arg.size() && arg[i + n] == c)
                ++n;
            out += padded_frame(frame, c == '#' && n == 1 ? 4 : n);  // # alone: 4 digits
            i += n;
            found = true;
            continue;
        }
        if (c == '%' && i + 1 < arg.size() && arg[i + 1] == '%') {
            out += '%';
            i += 2;
            continue;
        }
        if (c == '%') {
            std::size_t j = i + 1, width = 0;
            if (j < arg.size() && arg[j] == '0')
                for (++j; j < arg.size() && std::isdigit(static_cast<unsigned char>(arg[j])); ++j)
                    width = std::min<std::size_t>(width * 10 + std::size_t(arg[j] - '0'), 1000);
            if (j < arg.size() && arg[j] == 'd') {
                out += padded_frame(frame, width);
                i = j + 1;
                found = true;
                continue;
            }
        }
        out += c;
        ++i;
    }
    return out;
}

std::string with_udim(std::string arg, int tile)
{
    const std::string token = "<UDIM>";
    for (std::size_t at; (at = arg.find(token)) != std::string::npos;)
        arg.replace(at, token.size(), std::to_string(tile));
    return arg;
}

bool is_input(const std::vector<std::string>& args, std::size_t i)
{
    static const std::vector<std::string> takes_value = {"-o", "--report", "--log", "-d", "--compression",
                                                         "--device", "--batch", "--shard", "--frames"};
    if (args[i].empty() || args[i][0] == '-')
        return false;
    return i == 0 || std::find(takes_value.begin(), takes_value.end(), args[i - 1]) == takes_value.end();
}

// One argument list per UDIM tile of `args` (frames already substituted),
// or `args` alone when no argument holds <UDIM>.
std::vector<std::vector<std::string>> expand_udim(const std::vector<std::string>& args)
{
    bool udim = false;
    std::vector<int> tiles;
    for (std::size_t i = 0; i < args.size(); ++i) {
        if (args[i].find("<UDIM>") == std::string::npos)
            continue;
        udim = true;
        if (!is_input(args, i))
            continue;
        std::error_code ec;
        for (int t = 1001; t <= 1999; ++t)
            if (std::filesystem::exists(with_udim(args[i], t), ec))
                tiles.push_back(t);
        if (tiles.empty())
            throw UsageError("no UDIM tile (1001-1999) exists for '" + args[i] + "'");
        break;
    }
    if (!udim)
        return {args};
    if (tiles.empty())
        throw UsageError("<UDIM> in an output needs an input file name holding <UDIM> (its tiles are the ones made)");
    std::vector<std::vector<std::string>> jobs;
    for (const int tile : tiles) {
        jobs.push_back(args);
        for (std::string& a : jobs.back())
            a = with_udim(a, tile);
    }
    return jobs;
}

} // namespace

std::vector<std::vector<std::string>> expand_names(const std::vector<std::string>& given)
{
    std::vector<std::string> args;
    std::vector<int> frames;
    bool frames_given = false;
    for (std::size_t i = 0; i < given.size(); ++i) {
        if (given[i] == "--frames") {
            if (frames_given)
                throw UsageError("--frames is given twice (write all ranges in one: 1-10,20-30)");
            if (i + 1 >= given.size())
                throw UsageError("--frames needs a value (e.g. 1-10)");
            frames = parse_frames(given[++i]);
            frames_given = true;
        } else {
            args.push_back(given[i]);
        }
    }
    if (!frames_given)
        return expand_udim(args);
    // Frames outer, tiles inner: each frame's tiles are those that exist for it.
    std::vector<std::vector<std::string>> jobs;
    bool found = false;
    for (const int f : frames) {
        std::vector<std::string> framed = args;
        for (std::string& a : framed)
            a = with_frame(a, f, found);
        if (!found)
            throw UsageError("--frames: no argument holds a frame token (#, @, %04d)");
        try {
            for (auto& job : expand_udim(framed))
                jobs.push_back(std::move(job));
        } catch (const UsageError&) {
            jobs.push_back(framed);  // a frame without tiles: its job fails alone, naming the file
        }
    }
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
