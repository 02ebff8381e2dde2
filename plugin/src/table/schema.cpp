// SPDX-License-Identifier: Apache-2.0
// The operation table's schema: values checked against a modifier's type
// and range, numbers written as the command line reads them.
#include "schema.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "relief/errors.h"
#include "relief/imageio.h"
#include "relief/operations.h"

namespace relief {

// (public: relief/operations.h)
std::string range_text(const ModifierInfo& m)
{
    return detail::range_text(m.min, m.min_open, m.max, m.max_open, m.unit);
}

}  // namespace relief

namespace relief::table {

bool in_range(const ModifierInfo& m, double v)
{
    return (m.min_open ? v > m.min : v >= m.min) && (m.max_open ? v < m.max : v <= m.max);
}

std::string joined(const std::vector<std::string>& v, const char* sep)
{
    std::string s;
    for (const auto& x : v)
        s += (s.empty() ? "" : sep) + x;
    return s;
}

std::string listed(const std::vector<std::string>& names)
{
    std::string s;
    for (std::size_t i = 0; i < names.size(); ++i)
        s += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
    return s;
}

std::string word_prefix(const std::string& word)
{
    const std::size_t colon = word.find(':');
    return colon == std::string::npos ? std::string() : word.substr(0, colon + 1);
}

bool read_number(const std::string& text, double& v)
{
    const char* end = text.data() + text.size();
    const auto r = std::from_chars(text.data(), end, v);
    return !text.empty() && r.ec == std::errc() && r.ptr == end && std::isfinite(v);
}

double check_value(const ModifierInfo& m, const std::string& text)
{
    const std::string kv = m.name + "=" + text;
    for (const auto& w : m.choices)
        if (text == w)
            return 0.0;
    switch (m.type) {
    case ModifierType::Choice:
        throw std::invalid_argument(detail::not_one_of(m.name, text, joined(m.choices, "|")));
    case ModifierType::Integer: {
        long long v = 0;
        const char* end = text.data() + text.size();
        auto r = std::from_chars(text.data(), end, v);
        if (text.empty() || r.ec != std::errc() || r.ptr != end || v < m.min || v > m.max)
            throw std::invalid_argument(
                detail::out_of_range(m.name, text, true, range_text(m), joined(m.choices, "|")));
        return double(v);
    }
    case ModifierType::Number: {
        double v = 0.0;
        const char* end = text.data() + text.size();
        auto r = std::from_chars(text.data(), end, v);
        const bool overflow =
            r.ec == std::errc::result_out_of_range || (r.ec == std::errc() && !std::isfinite(v));
        if (text.empty() || r.ptr != end || (r.ec != std::errc() && !overflow) || std::isnan(v))
            throw std::invalid_argument(detail::not_a_number(m.name, text));
        if (overflow || !in_range(m, v))  // inf, 1e999
            throw std::invalid_argument(
                detail::out_of_range(m.name, text, false, range_text(m), joined(m.choices, "|")));
        return v;
    }
    case ModifierType::Output:
    case ModifierType::Text: return 0.0;  // checked by the modifier's set()
    case ModifierType::File: {
        for (const auto& w : m.choices) {
            const std::string p = word_prefix(w);
            if (!p.empty() && text.compare(0, p.size(), p) == 0)
                return 0.0;  // checked by the modifier's set()
        }
        const std::string why = text.empty() ? "no such file" : input_file_problem(text);
        if (!why.empty())
            throw std::invalid_argument(kv + ": " + why);
        return 0.0;
    }
    }
    return 0.0;
}

const ImageBuf* file_image(const ImageBuf* given, const std::string& path, const char* what,
                           ImageBuf& storage)
{
    if (given || path.empty())
        return given;
    if (!read_image(storage, path))
        throw std::runtime_error(std::string(what) + ": " + geterror());
    return &storage;
}

const ImageBuf& file_to_come()
{
    // Never destroyed: the image library may be torn down first at exit.
    static const ImageBuf* const image = new ImageBuf();
    return *image;
}

const ImageSlot kNormals{"normals", 2, 4,
                         "tangent-space normal map: 8/16-bit UNORM, half or float; 2 channels "
                         "rebuild z, a 4th is alpha"};
const ImageSlot kHeight{"height", 1, 4096, "displacement in texels; channel 0 is used"};

}  // namespace relief::table
