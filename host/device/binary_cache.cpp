// SPDX-License-Identifier: Apache-2.0
#include "device/binary_cache.h"

#include <unistd.h>
#include <xxhash.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace relief::host {

namespace fs = std::filesystem;

namespace {

// The file: this magic, the XXH64 of the payload (16 hex digits), '\n', the payload.
constexpr char kMagic[] = "relief-binary-1 ";

std::string hex64(unsigned long long v)
{
    char s[17];
    std::snprintf(s, sizeof s, "%016llx", v);
    return s;
}

}  // namespace

std::string BinaryCache::folder()
{
    const char* own = std::getenv("RELIEF_CACHE_DIR");
    if (own && *own)
        return std::strcmp(own, "off") == 0 ? std::string() : std::string(own);
    const char* xdg = std::getenv("XDG_CACHE_HOME");
    if (xdg && *xdg)
        return std::string(xdg) + "/relief";
    const char* home = std::getenv("HOME");
    if (home && *home)
        return std::string(home) + "/.cache/relief";
    return "";
}

std::string BinaryCache::key(const std::vector<std::string>& parts)
{
    XXH3_state_t* state = XXH3_createState();
    XXH3_128bits_reset(state);
    for (const std::string& p : parts) {
        const unsigned long long n = p.size();
        XXH3_128bits_update(state, &n, sizeof n);
        XXH3_128bits_update(state, p.data(), p.size());
    }
    const XXH128_hash_t h = XXH3_128bits_digest(state);
    XXH3_freeState(state);
    return hex64(h.high64) + hex64(h.low64);
}

std::optional<std::string> BinaryCache::load(const std::string& key)
{
    const std::string dir = folder();
    if (dir.empty())
        return std::nullopt;
    std::ifstream in(dir + "/" + key + ".bin", std::ios::binary);
    if (!in)
        return std::nullopt;
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t head = sizeof kMagic - 1 + 16 + 1;
    if (text.size() <= head || text.compare(0, sizeof kMagic - 1, kMagic) != 0 || text[head - 1] != '\n')
        return std::nullopt;
    std::string payload = text.substr(head);
    if (text.compare(sizeof kMagic - 1, 16, hex64(XXH64(payload.data(), payload.size(), 0))) != 0)
        return std::nullopt;
    return payload;
}

void BinaryCache::store(const std::string& key, const std::string& bytes)
{
    const std::string dir = folder();
    if (dir.empty() || bytes.empty())
        return;
    std::error_code ec;
    fs::create_directories(dir, ec);
    static std::atomic<int> counter{0};
    const std::string tmp =
        dir + "/." + key + "." + std::to_string(::getpid()) + "." + std::to_string(counter++) + ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary);
        out << kMagic << hex64(XXH64(bytes.data(), bytes.size(), 0)) << '\n';
        out.write(bytes.data(), std::streamsize(bytes.size()));
        out.close();
        if (!out) {
            fs::remove(tmp, ec);
            return;
        }
    }
    fs::rename(tmp, dir + "/" + key + ".bin", ec);
    if (ec)
        fs::remove(tmp, ec);
}

}  // namespace relief::host
