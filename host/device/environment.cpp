// SPDX-License-Identifier: Apache-2.0
#include "device/environment.h"

#include <cerrno>
#include <cstdlib>
#include <string>

#include "errors.h"

namespace relief::host {

std::uint64_t size_from_environment(const char* name)
{
    const char* text = std::getenv(name);
    if (!text || !*text)
        return 0;
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(text, &end);
    // K, M, G, T (either case): powers of 1024, as memory is counted.
    static const char kSuffixes[] = "KMGT";
    std::uint64_t scale = 1;
    for (int k = 0; *end && k < 4; ++k)
        if (*end == kSuffixes[k] || *end == kSuffixes[k] - 'A' + 'a') {
            scale = std::uint64_t(1) << (10 * (k + 1));
            ++end;
            break;
        }
    if (end == text || *end || errno || !(v > 0) || v * double(scale) < 1.0 || v * double(scale) > 1e18)
        throw Error(std::string(name) + " must be a size in bytes > 0 (suffix K, M, G or T allowed), not '" +
                    text + "'");
    return std::uint64_t(v * double(scale));
}

std::uint64_t count_from_environment(const char* name, const char* unit)
{
    const char* text = std::getenv(name);
    if (!text || !*text)
        return 0;
    char* end = nullptr;
    errno = 0;
    const unsigned long long v = std::strtoull(text, &end, 10);
    if (*end || errno || v == 0 || text[0] == '-')
        throw Error(std::string(name) + " must be " +
                    (unit ? std::string("a number of ") + unit : std::string("a whole number")) +
                    " > 0, not '" + text + "'");
    return v;
}

}  // namespace relief::host
