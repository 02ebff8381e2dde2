// SPDX-License-Identifier: Apache-2.0
// The wording of numbers and ranges that the table and validate() share.
#include "option_limits.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace relief::detail {

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

std::string range_text(double min, bool min_open, double max, bool max_open, const std::string& unit)
{
    const std::string r = std::string(min_open ? "(" : "[") + number_text(min) + ", " + number_text(max) +
                          (max_open ? ")" : "]");
    return unit.empty() ? r : r + " " + unit;
}

std::string range_text(const Limits& l)
{
    return range_text(l.min, l.min_open, l.max, l.max_open, l.unit);
}

bool within(const Limits& l, double v)
{
    if (l.zero_word && v == 0.0)
        return true;
    if (l.integer && v != std::floor(v))
        return false;
    return (l.min_open ? v > l.min : v >= l.min) && (l.max_open ? v < l.max : v <= l.max);
}

std::string out_of_range(const std::string& name, const std::string& value, bool integer,
                         const std::string& range, const std::string& words)
{
    return name + "=" + value + (integer ? " must be an integer in " : " is out of range; it must be in ") +
           range + (words.empty() ? "" : " or " + words);
}

std::string not_one_of(const std::string& name, const std::string& value, const std::string& choices)
{
    return name + "=" + value + " is not one of " + choices;
}

std::string not_a_number(const std::string& name, const std::string& value)
{
    return name + "=" + value + " is not a number";
}

std::string range_problem(const Limits& l, double v)
{
    if (within(l, v))
        return "";
    if (std::isnan(v))
        return not_a_number(l.name, "nan");
    return out_of_range(l.name, number_text(v), l.integer, range_text(l), l.zero_word ? l.zero_word : "");
}

}  // namespace relief::detail
