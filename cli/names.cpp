// SPDX-License-Identifier: Apache-2.0
#include "names.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <map>
#include <system_error>

#include "command_line.h"

namespace relief::cli {

namespace {

// "1-10,20,30-32", with oiiotool's steps: "1-10x3" every third frame from
// the first (1 4 7 10), "1-10y3" the others (2 3 5 6 8 9) -> every frame,
// in the order given. Throws UsageError.
std::vector<int> parse_frames(const std::string& text)
{
    constexpr long long kLimit = 1000000000;  // |frame| <= 10^9: no overflow below
    std::vector<int> frames;
    const auto bad = [&text] {
        return UsageError("--frames " + text +
                          ": write ranges like 1-10,20,30-32 or 1-9x2 (every second frame; y2: "
                          "the others) (A <= B, step >= 1, |frames| <= 10^9, at most 100000 frames)");
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
        std::string part = text.substr(pos, comma - pos);
        long long step = 1;
        bool others = false;  // y: the frames the x step leaves out
        if (const std::size_t x = part.find_first_of("xy"); x != std::string::npos) {
            others = part[x] == 'y';
            step = number(part.data() + x + 1, part.data() + part.size());
            part.resize(x);
            if (step < 1)
                throw bad();
        }
        const std::size_t dash = part.empty() ? std::string::npos : part.find('-', 1);
        const char* begin = part.data();
        const char* end = begin + part.size();
        const char* mid = dash == std::string::npos ? end : begin + dash;
        const long long first = number(begin, mid);
        const long long last = dash == std::string::npos ? first : number(mid + 1, end);
        if (last < first)
            throw bad();
        for (long long f = first; f <= last; ++f) {
            if (((f - first) % step == 0) == others)
                continue;
            if (frames.size() >= 100000)
                throw bad();
            frames.push_back(int(f));
        }
        pos = comma + 1;
    }
    if (frames.empty())  // (a y step of 1 leaves none)
        throw bad();
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
    // Only the file-name part: a folder "shots/#12" or "/mnt/a@b" is kept.
    const std::size_t slash = arg.rfind('/');
    std::string out = slash == std::string::npos ? std::string() : arg.substr(0, slash + 1);
    for (std::size_t i = out.size(); i < arg.size();) {
        const char c = arg[i];
        if (c == '%' && i + 1 < arg.size() && (arg[i + 1] == '#' || arg[i + 1] == '@')) {
            out += arg[i + 1];  // %# and %@: a literal # or @
            i += 2;
            continue;
        }
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

// The tile tokens, as OpenImageIO's texture system names them: <UDIM> is
// 1001 + u + 10 v; <UVTILE> is u<U>_v<V> (Mudbox's u1_v1); <u> <v> count
// tiles from 0, <U> <V> from 1. Tiles are held as UDIM numbers throughout.
const std::string kTileTokens[] = {"<UDIM>", "<UVTILE>", "<u>", "<v>", "<U>", "<V>"};

bool has_tile_token(const std::string& arg)
{
    return std::any_of(std::begin(kTileTokens), std::end(kTileTokens),
                       [&](const std::string& t) { return arg.find(t) != std::string::npos; });
}

std::string tile_text(const std::string& token, int tile)
{
    const int u = (tile - 1001) % 10, v = (tile - 1001) / 10;
    if (token == "<UDIM>")
        return std::to_string(tile);
    if (token == "<UVTILE>")
        return "u" + std::to_string(u + 1) + "_v" + std::to_string(v + 1);
    if (token == "<u>" || token == "<U>")
        return std::to_string(token == "<U>" ? u + 1 : u);
    return std::to_string(token == "<V>" ? v + 1 : v);
}

std::string with_udim(const std::string& arg, int tile)
{
    std::string out;
    for (std::size_t i = 0; i < arg.size();) {
        const auto* token =
            std::find_if(std::begin(kTileTokens), std::end(kTileTokens),
                         [&](const std::string& t) { return arg.compare(i, t.size(), t) == 0; });
        if (token != std::end(kTileTokens)) {
            out += tile_text(*token, tile);
            i += token->size();
        } else {
            out += arg[i++];
        }
    }
    return out;
}

// The tile a file name is of, read against its pattern (tokens at
// `pieces` boundaries: pieces[k] + token k + pieces[k + 1] ...): 0 when the
// name is not one of the pattern's tiles. A number is read greedily (1 to 4
// digits) and the name is then rebuilt from the tile, so leading zeros and
// tokens that disagree (<u> 3 and <U> 5) do not match.
int tile_of(const std::string& name, const std::string& pattern, const std::vector<std::string>& pieces,
            const std::vector<std::string>& tokens)
{
    int u = 0, v = 0;
    std::size_t at = 0;
    const auto digits = [&](int& value) {
        std::size_t n = 0;
        while (n < 4 && at + n < name.size() && std::isdigit(static_cast<unsigned char>(name[at + n])))
            ++n;
        if (n == 0)
            return false;
        value = std::stoi(name.substr(at, n));
        at += n;
        return true;
    };
    const auto literal = [&](const std::string& text) {
        if (name.compare(at, text.size(), text) != 0)
            return false;
        at += text.size();
        return true;
    };
    for (std::size_t k = 0; k < tokens.size(); ++k) {
        if (!literal(pieces[k]))
            return 0;
        const std::string& t = tokens[k];
        int a = 0, b = 0;
        if (t == "<UDIM>") {
            if (!digits(a) || a < 1001 || a > 1999)
                return 0;
            u = (a - 1001) % 10;
            v = (a - 1001) / 10;
        } else if (t == "<UVTILE>") {
            if (!literal("u") || !digits(a) || !literal("_v") || !digits(b) || a < 1 || b < 1)
                return 0;
            u = a - 1;
            v = b - 1;
        } else if (!digits(a)) {
            return 0;
        } else if (t == "<u>" || t == "<U>") {
            u = t == "<U>" ? a - 1 : a;
        } else {
            v = t == "<V>" ? a - 1 : a;
        }
    }
    if (!literal(pieces.back()) || at != name.size() || u < 0 || u > 9 || v < 0 || v > 99)
        return 0;
    const int tile = 1001 + u + 10 * v;
    return with_udim(pattern, tile) == name ? tile : 0;
}

bool is_input(const std::vector<std::string>& args, std::size_t i)
{
    static const std::vector<std::string> takes_value = {
        "-o", "--report", "--log", "-d", "--compression", "--device", "--batch", "--shard", "--frames"};
    if (args[i].empty() || args[i][0] == '-')
        return false;
    return i == 0 || std::find(takes_value.begin(), takes_value.end(), args[i - 1]) == takes_value.end();
}

constexpr std::size_t kMaxExpandedBytes = std::size_t(64) << 20;  // 100000 frames of 670 bytes

// The UDIM tiles (1001-1999) that exist for a name holding <UDIM>. A line
// with --frames asks once per frame: each folder is listed once and its
// names matched against the pattern, where 999 existence checks per frame
// took minutes for 100000 frames.
class TileFinder {
public:
    std::vector<int> tiles(const std::string& pattern)
    {
        const std::size_t slash = pattern.rfind('/');
        const std::string folder_pattern = slash == std::string::npos ? "" : pattern.substr(0, slash + 1);
        const std::string name_pattern = pattern.substr(folder_pattern.size());
        std::vector<std::string> pieces, tokens;  // the name around its tokens, and they
        for (std::size_t from = 0;;) {
            std::size_t at = std::string::npos;
            const std::string* token = nullptr;
            for (const std::string& t : kTileTokens)
                if (const std::size_t found = name_pattern.find(t, from); found < at) {
                    at = found;
                    token = &t;
                }
            pieces.push_back(name_pattern.substr(from, at - from));
            if (!token)
                break;
            tokens.push_back(*token);
            from = at + token->size();
        }
        std::vector<int> found;
        for (const auto& [folder_tile, folder] : folders(folder_pattern)) {
            if (pieces.size() == 1) {  // the token is in the folder only
                std::error_code ec;
                if (std::filesystem::exists(folder + name_pattern, ec))
                    found.push_back(folder_tile);
                continue;
            }
            const std::vector<std::string>& names = listing(folder);
            for (auto it = std::lower_bound(names.begin(), names.end(), pieces[0]);
                 it != names.end() && it->compare(0, pieces[0].size(), pieces[0]) == 0; ++it) {
                const std::string& name = *it;
                const int tile = tile_of(name, name_pattern, pieces, tokens);
                if (tile == 0 || (folder_tile != 0 && tile != folder_tile))
                    continue;
                std::error_code ec;  // (a dangling link is listed but does not exist)
                if (std::filesystem::exists(folder + name, ec))
                    found.push_back(tile);
            }
        }
        std::sort(found.begin(), found.end());
        found.erase(std::unique(found.begin(), found.end()), found.end());
        return found;
    }

private:
    // (tile, folder) for each folder the pattern names: tile 0 and the
    // folder itself when it holds no token.
    const std::vector<std::pair<int, std::string>>& folders(const std::string& pattern)
    {
        auto [it, added] = folders_.try_emplace(pattern);
        if (added) {
            if (!has_tile_token(pattern)) {
                it->second.emplace_back(0, pattern);
            } else {
                for (int t = 1001; t <= 1999; ++t) {
                    std::error_code ec;
                    if (std::filesystem::is_directory(with_udim(pattern, t), ec))
                        it->second.emplace_back(t, with_udim(pattern, t));
                }
            }
        }
        return it->second;
    }

    // The names in `folder` ("" = the working folder), sorted; none where
    // it cannot be read.
    const std::vector<std::string>& listing(const std::string& folder)
    {
        auto [it, added] = listings_.try_emplace(folder);
        if (added) {
            std::error_code ec;
            for (std::filesystem::directory_iterator d(folder.empty() ? "." : folder, ec), end;
                 !ec && d != end; d.increment(ec))
                it->second.push_back(d->path().filename().string());
            std::sort(it->second.begin(), it->second.end());
        }
        return it->second;
    }

    std::map<std::string, std::vector<std::pair<int, std::string>>> folders_;
    std::map<std::string, std::vector<std::string>> listings_;
};

// One argument list per UDIM tile of `args` (frames already substituted),
// or `args` alone when no argument holds <UDIM>. Where there is none, says
// why in `error` and returns nothing (a line of many frames meets this once
// a frame: no exception there).
std::vector<Expansion> expand_udim(const std::vector<std::string>& args, TileFinder& finder,
                                   std::string& error)
{
    bool udim = false;
    std::vector<int> tiles;
    for (std::size_t i = 0; i < args.size(); ++i) {
        if (!has_tile_token(args[i]))
            continue;
        udim = true;
        if (!is_input(args, i))
            continue;
        tiles = finder.tiles(args[i]);
        if (tiles.empty()) {
            error = "no UDIM tile (1001-1999) exists for '" + args[i] + "'";
            return {};
        }
        break;
    }
    if (!udim)
        return {{args, 0, args}};
    if (tiles.empty()) {
        error = "a tile token (<UDIM>, <UVTILE>) in an output needs an input file name holding one (its "
                "tiles are the ones made)";
        return {};
    }
    std::vector<Expansion> jobs;
    for (const int tile : tiles) {
        jobs.push_back({args, tile, args});
        for (std::string& a : jobs.back().args)
            a = with_udim(a, tile);
    }
    return jobs;
}

// Refuses expansions that would write one file more than once: an output
// (-o, --report) named without the token of what the line runs over would
// be overwritten by each tile or frame, and --update would never settle.
void refuse_shared_outputs(const std::vector<Expansion>& jobs)
{
    if (jobs.size() < 2)
        return;
    std::map<std::string, int> writers;
    for (const Expansion& e : jobs)
        for (std::size_t i = 0; i + 1 < e.args.size(); ++i)
            if (e.args[i] == "-o" || e.args[i] == "--report")
                ++writers[e.args[i] + " " + e.args[i + 1]];
    for (const auto& [output, count] : writers)
        if (count > 1)
            throw UsageError(output + ": " + std::to_string(count) + " of this line's " +
                             std::to_string(jobs.size()) +
                             " tiles and frames would each write it; put the tile token (<UDIM>, "
                             "<UVTILE>) or a frame token (#, %04d) in the name");
}

}  // namespace

std::vector<std::vector<std::string>> expand_names(const std::vector<std::string>& given)
{
    std::vector<std::vector<std::string>> lists;
    for (Expansion& e : expand_names_with_tiles(given))
        lists.push_back(std::move(e.args));
    return lists;
}

std::vector<Expansion> expand_names_with_tiles(const std::vector<std::string>& given)
{
    std::vector<std::string> args;
    std::vector<int> frames;
    bool frames_given = std::find(given.begin(), given.end(), "--frames") != given.end();
    // The manifest and the log are one file for the whole run: a token in
    // them would silently name only the first tile's or frame's.
    for (std::size_t i = 0; i + 1 < given.size(); ++i)
        if (given[i] == "--batch" || given[i] == "--log") {
            bool frame_token = false;
            with_frame(given[i + 1], 0, frame_token);
            if (has_tile_token(given[i + 1]) || (frames_given && frame_token))
                throw UsageError(
                    given[i] + " " + given[i + 1] +
                    ": names one file for the whole run; tile (<UDIM>, <UVTILE>) and frame tokens are "
                    "not expanded there (with --frames, write %# or %@ for a literal # or @)");
        }
    frames_given = false;
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
    TileFinder finder;
    std::string error;
    if (!frames_given) {
        auto jobs = expand_udim(args, finder, error);
        if (!error.empty())
            throw UsageError(error);
        refuse_shared_outputs(jobs);
        return jobs;
    }
    // Frames outer, tiles inner: each frame's tiles are those that exist for it.
    std::vector<Expansion> jobs;
    std::size_t held = 0;
    bool found = false;
    for (const int f : frames) {
        std::vector<std::string> framed = args;
        for (std::string& a : framed)
            a = with_frame(a, f, found);
        if (!found)
            throw UsageError("--frames: no argument holds a frame token (#, @, %04d)");
        auto tiles = expand_udim(framed, finder, error);
        if (tiles.empty())  // a frame without tiles: its job fails alone, naming the file
            tiles.push_back({framed, 0, framed});
        for (auto& job : tiles) {
            // The jobs are held in memory at once: 100000 frames of a 64 KiB
            // line would be 6 GiB.
            for (const std::string& a : job.args)
                held += a.size() + sizeof(std::string);
            if (held > kMaxExpandedBytes)
                throw UsageError("--frames: the jobs of this line's " + std::to_string(frames.size()) +
                                 " frames hold more than " + std::to_string(kMaxExpandedBytes >> 20) +
                                 " MiB of arguments (fewer frames or tiles per line)");
            jobs.push_back(std::move(job));
        }
    }
    refuse_shared_outputs(jobs);
    return jobs;
}

}  // namespace relief::cli
