// SPDX-License-Identifier: Apache-2.0
#include "job_digest.h"

#include <xxhash.h>

#include "relief/imageio.h"

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <vector>

namespace relief::cli {

namespace {

class Hasher {
public:
    Hasher() : state_(XXH3_createState(), XXH3_freeState) { XXH3_128bits_reset(state_.get()); }

    // Length first, so that no two sequences of texts feed the same bytes.
    void text(const std::string& s)
    {
        const unsigned long long n = s.size();
        XXH3_128bits_update(state_.get(), &n, sizeof n);
        XXH3_128bits_update(state_.get(), s.data(), s.size());
    }

    void file(const std::string& path)
    {
        if (const std::string why = relief::input_file_problem(path); !why.empty())
            throw std::runtime_error("cannot read '" + path + "': " + why);
        std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), std::fclose);
        if (!f)
            throw std::runtime_error("cannot read '" + path + "'");
        XXH3_state_t* inner = XXH3_createState();
        XXH3_128bits_reset(inner);
        std::vector<char> buf(1 << 20);
        std::size_t n;
        while ((n = std::fread(buf.data(), 1, buf.size(), f.get())) > 0)
            XXH3_128bits_update(inner, buf.data(), n);
        const bool failed = std::ferror(f.get());
        const XXH128_hash_t h = XXH3_128bits_digest(inner);
        XXH3_freeState(inner);
        if (failed)
            throw std::runtime_error("cannot read '" + path + "': read error");
        text(hex(h));
    }

    std::string digest() const { return hex(XXH3_128bits_digest(state_.get())); }

private:
    static std::string hex(XXH128_hash_t h)
    {
        char s[33];
        std::snprintf(s, sizeof s, "%016llx%016llx", static_cast<unsigned long long>(h.high64),
                      static_cast<unsigned long long>(h.low64));
        return s;
    }

    std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state_;
};

std::string digest_of(const Program& prog)
{
    Hasher h;
    h.text("relief job digest 1");
    // The same for every job of the process (it hashes every kernel source).
    static const std::string implementation = implementation_digest();
    h.text(implementation);
    for (const Step& s : prog.steps) {
        switch (s.kind) {
        case Step::Kind::Read:
            h.text("read");
            h.file(s.path);
            break;
        case Step::Kind::Operation: {
            // the files it reads (mask=, fix=, env=) count by their bytes,
            // not their names, in the table's order
            h.text(s.operation);
            h.text(modifier_text(relief::without_files_read(s)));
            for (const std::string& file : relief::files_read(s)) {
                h.text("file read");
                h.file(file);
            }
            break;
        }
        case Step::Kind::Dup: h.text("dup"); break;
        case Step::Kind::Write:
            h.text("write");
            h.text(std::string(s.format.c_str()) + (s.format_given ? " given" : " default"));
            h.text(s.compression);
            break;
        }
    }
    return h.digest();
}

}  // namespace

std::string job_digest(const Program& prog)
{
    try {
        return digest_of(prog);
    } catch (const std::runtime_error&) {
        return "";
    }
}

std::vector<std::string> output_files(const Program& prog)
{
    std::vector<std::string> v;
    for (const Step& s : prog.steps) {
        if (s.kind == Step::Kind::Write)
            v.push_back(s.path);
        if (s.kind == Step::Kind::Operation)
            for (const std::string& f : relief::files_written(s))
                v.push_back(f);
    }
    return v;
}

std::string tile_set_digest(const std::vector<Program>& tiles, const std::vector<int>& numbers)
{
    Hasher h;
    h.text("relief tile set digest 1");
    for (std::size_t i = 0; i < tiles.size(); ++i) {
        const std::string d = job_digest(tiles[i]);
        if (d.empty())
            return "";
        h.text(std::to_string(numbers[i]));
        h.text(d);
    }
    return h.digest();
}

std::string output_digest(const std::string& job, int output)
{
    if (job.empty())
        return "";
    Hasher h;
    h.text(job);
    h.text("output " + std::to_string(output));
    return h.digest();
}

}  // namespace relief::cli
