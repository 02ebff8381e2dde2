// SPDX-License-Identifier: Apache-2.0
// The operation table as a JSON document (relief::operations_json), what
// the C ABI and Python hand to programs that build their own front ends.
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "relief/relief_c.h"
#include "schema.h"

namespace relief {

namespace {

std::string json_string(const std::string& s)
{
    std::string out = "\"";
    for (const char ch : s) {
        const unsigned char u = static_cast<unsigned char>(ch);
        if (ch == '"' || ch == '\\')
            out += std::string("\\") + ch;
        else if (u < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", u);
            out += buf;
        } else
            out += ch;
    }
    return out + "\"";
}

const char* type_name(ModifierType t)
{
    switch (t) {
    case ModifierType::Choice: return "choice";
    case ModifierType::Integer: return "integer";
    case ModifierType::Number: return "number";
    case ModifierType::File: return "file";
    case ModifierType::Output: return "output";
    case ModifierType::Text: return "text";
    }
    return "?";
}

std::string json_slots(const std::vector<ImageSlot>& slots)
{
    std::string s = "[";
    for (std::size_t i = 0; i < slots.size(); ++i)
        s += std::string(i ? ", " : "") + "{\"name\": " + json_string(slots[i].name) +
             ", \"min_channels\": " + std::to_string(slots[i].min_channels) +
             ", \"max_channels\": " + std::to_string(slots[i].max_channels) +
             ", \"meaning\": " + json_string(slots[i].meaning) + "}";
    return s + "]";
}

}  // namespace

std::string operations_json()
{
    std::ostringstream j;
    j << "{\"abi_version\": " << RELIEF_ABI_VERSION << ", \"operations\": [";
    bool first_op = true;
    for (const OperationInfo& op : operations()) {
        j << (first_op ? "\n" : ",\n") << "  {\"name\": " << json_string(op.name)
          << ", \"summary\": " << json_string(op.summary) << ",\n   \"inputs\": " << json_slots(op.inputs)
          << ",\n   \"outputs\": " << json_slots(op.outputs) << ",\n   \"modifiers\": [";
        first_op = false;
        bool first = true;
        for (const ModifierInfo& m : op.modifiers) {
            j << (first ? "\n" : ",\n") << "    {\"name\": " << json_string(m.name) << ", \"type\": \""
              << type_name(m.type) << "\"";
            first = false;
            j << ", \"choices\": [";
            for (std::size_t i = 0; i < m.choices.size(); ++i)
                j << (i ? ", " : "") << json_string(m.choices[i]);
            j << "]";
            if (m.type == ModifierType::Integer || m.type == ModifierType::Number)
                j << ", \"min\": " << table::number_text(m.min) << ", \"max\": " << table::number_text(m.max)
                  << ", \"min_open\": " << (m.min_open ? "true" : "false")
                  << ", \"max_open\": " << (m.max_open ? "true" : "false")
                  << ", \"unit\": " << json_string(m.unit);
            j << ", \"default\": " << json_string(m.default_value)
              << ", \"applies_to\": " << json_string(m.applies_to)
              << ", \"meaning\": " << json_string(m.meaning) << "}";
        }
        j << "]}";
    }
    j << "\n]}\n";
    return j.str();
}

}  // namespace relief
