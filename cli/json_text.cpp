// SPDX-License-Identifier: Apache-2.0
#include "json_text.h"

#include <cstdio>

namespace relief::cli {

namespace {

// Bytes that are not UTF-8 travel through nlohmann::json as the code points
// U+10FF80 + (B - 0x80) of the private-use plane 16, which json_text() then
// writes as \udcXX. A name that holds those code points itself has their
// bytes escaped the same way, so every string comes back as it was.
constexpr unsigned kFirstMarker = 0x10FF80;

std::size_t utf8_length(const std::string& s, std::size_t i, unsigned& cp)
{
    const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
    const unsigned b0 = byte(i);
    std::size_t n;
    if (b0 < 0x80) {
        cp = b0;
        return 1;
    } else if (b0 >= 0xC2 && b0 <= 0xDF) {
        n = 2;
        cp = b0 & 0x1F;
    } else if (b0 >= 0xE0 && b0 <= 0xEF) {
        n = 3;
        cp = b0 & 0x0F;
    } else if (b0 >= 0xF0 && b0 <= 0xF4) {
        n = 4;
        cp = b0 & 0x07;
    } else {
        return 0;
    }
    if (i + n > s.size())
        return 0;
    for (std::size_t k = 1; k < n; ++k) {
        if ((byte(i + k) & 0xC0) != 0x80)
            return 0;
        cp = (cp << 6) | (byte(i + k) & 0x3F);
    }
    // overlong forms, surrogates and past U+10FFFF are not UTF-8
    if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10FFFF)) ||
        (cp >= 0xD800 && cp <= 0xDFFF))
        return 0;
    return n;
}

void append_utf8(std::string& out, unsigned cp)
{
    out += char(0xF0 | (cp >> 18));
    out += char(0x80 | ((cp >> 12) & 0x3F));
    out += char(0x80 | ((cp >> 6) & 0x3F));
    out += char(0x80 | (cp & 0x3F));
}

}  // namespace

Json json_bytes(const std::string& bytes)
{
    std::string text;
    text.reserve(bytes.size());
    for (std::size_t i = 0; i < bytes.size();) {
        unsigned cp = 0;
        const std::size_t n = utf8_length(bytes, i, cp);
        if (n > 0 && cp < kFirstMarker) {
            text.append(bytes, i, n);
            i += n;
            continue;
        }
        const std::size_t raw = n > 0 ? n : 1;  // a marker's own bytes, or one stray byte
        for (std::size_t k = 0; k < raw; ++k)
            append_utf8(text, kFirstMarker + (static_cast<unsigned char>(bytes[i + k]) - 0x80));
        i += raw;
    }
    return Json(text);
}

Json json_bytes(const std::vector<std::string>& list)
{
    Json array = Json::array();
    for (const std::string& s : list)
        array.push_back(json_bytes(s));
    return array;
}

std::string json_text(const Json& value, int indent)
{
    const std::string dumped = value.dump(indent);
    std::string out;
    out.reserve(dumped.size());
    for (std::size_t i = 0; i < dumped.size();) {
        unsigned cp = 0;
        const std::size_t n = utf8_length(dumped, i, cp);
        if (n == 4 && cp >= kFirstMarker) {
            char escape[8];
            std::snprintf(escape, sizeof escape, "\\udc%02x", 0x80 + (cp - kFirstMarker));
            out += escape;
            i += 4;
        } else {
            out += dumped[i++];
        }
    }
    return out;
}

}  // namespace relief::cli
