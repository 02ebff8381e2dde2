// SPDX-License-Identifier: Apache-2.0
#include "device/environment.h"

#include <cerrno>
#include <cstdlib>
#include <string>

#include "errors.h"

namespace relief::host {

SizeSetting size_setting_from_environment(const char* name)
{
    SizeSetting out;
    const char* text = std::getenv(name);
    if (!text || !*text)
        return out;
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(text, &end);
    // K, M, G, T (either case) alone or with "iB": powers of 1024, as memory
    // is counted; with "B": powers of 1000, as it is sold.
    static const char kPrefixes[] = "KMGT";
    std::uint64_t scale = 1;
    for (int k = 0; *end && k < 4; ++k)
        if (*end == kPrefixes[k] || *end == kPrefixes[k] - 'A' + 'a') {
            const std::string unit = end + 1;
            if (unit.empty() || unit == "iB") {
                scale = std::uint64_t(1) << (10 * (k + 1));
                out.binary = true;
            } else if (unit == "B") {
                scale = 1;
                for (int i = 0; i <= k; ++i)
                    scale *= 1000;
            } else {
                break;
            }
            end += 1 + unit.size();
            break;
        }
    if (end == text || *end || errno || !(v > 0) || v * double(scale) < 1.0 || v * double(scale) > 1e18)
        throw Error(std::string(name) +
                    " must be a size in bytes > 0: a number, or with K, M, G or T (KiB... TiB: powers of "
                    "1024) or kB, MB, GB or TB (powers of 1000), not '" +
                    text + "'");
    out.bytes = std::uint64_t(v * double(scale));
    out.text = text;
    return out;
}

std::uint64_t size_from_environment(const char* name)
{
    return size_setting_from_environment(name).bytes;
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
