// The operation table's schema: values checked against a modifier's type
// and range, numbers written as the command line reads them.
#include "schema.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "relief/errors.h"
#include "relief/imageio.h"

namespace relief {

// (public: relief/operations.h)
std::string range_text(const ModifierInfo& m)
{
    std::string r = std::string(m.min_open ? "(" : "[") + table::number_text(m.min) + ", " +
                    table::number_text(m.max) + (m.max_open ? ")" : "]");
    return m.unit.empty() ? r : r + " " + m.unit;
}

} // namespace relief

namespace relief::table {

std::string number_text(double v)
{
    char buf[40];
    if (v == std::floor(v) && std::fabs(v) < 1e7) {
        std::snprintf(buf, sizeof buf, "%.0f", v);
        return buf;
    }
    for (int digits = 6; digits <= 17; ++digits) {  // %g's own 6 first: "0.5", not "5e-01"
        std::snprintf(buf, sizeof buf, "%.*g", digits, v);
        if (float(std::strtod(buf, nullptr)) == float(v))
            break;
    }
    return buf;
}

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

double check_value(const ModifierInfo& m, const std::string& text)
{
    const std::string kv = m.name + "=" + text;
    for (const auto& w : m.choices)
        if (text == w)
            return 0.0;
    switch (m.type) {
    case ModifierType::Choice:
        throw std::invalid_argument(kv + " is not one of " + joined(m.choices, "|"));
    case ModifierType::Integer: {
        long long v = 0;
        const char* end = text.data() + text.size();
        auto r = std::from_chars(text.data(), end, v);
        if (text.empty() || r.ec != std::errc() || r.ptr != end || v < m.min || v > m.max)
            throw std::invalid_argument(kv + " must be an integer in " + range_text(m) +
                                        (m.choices.empty() ? "" : " or " + joined(m.choices, "|")));
        return double(v);
    }
    case ModifierType::Number: {
        double v = 0.0;
        const char* end = text.data() + text.size();
        auto r = std::from_chars(text.data(), end, v);
        const bool overflow = r.ec == std::errc::result_out_of_range || (r.ec == std::errc() && !std::isfinite(v));
        if (text.empty() || r.ptr != end || (r.ec != std::errc() && !overflow) || std::isnan(v))
            throw std::invalid_argument(kv + " is not a number");
        if (overflow || !in_range(m, v))  // inf, 1e999
            throw std::invalid_argument(kv + " is out of range; it must be in " + range_text(m) +
                                        (m.choices.empty() ? "" : " or " + joined(m.choices, "|")));
        return v;
    }
    case ModifierType::Output:
    case ModifierType::Text:
        return 0.0;  // checked by the modifier's set()
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

const ImageSlot kNormals{"normals", 2, 4,
                         "tangent-space normal map: 8/16-bit UNORM, half or float; 2 channels "
                         "rebuild z, a 4th is alpha"};
const ImageSlot kHeight{"height", 1, 4096, "displacement in texels; channel 0 is used"};

} // namespace relief::table
