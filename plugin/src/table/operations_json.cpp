// SPDX-License-Identifier: Apache-2.0
// The operation table as a JSON document (relief::operations_json), what
// the C ABI and Python hand to programs that build their own front ends.
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "relief/relief_c.h"
#include "relief/operations.h"
#include "schema.h"

namespace relief {

namespace {

using Json = nlohmann::ordered_json;

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

Json json_slots(const std::vector<ImageSlot>& slots)
{
    Json list = Json::array();
    for (const ImageSlot& slot : slots)
        list.push_back({{"name", slot.name},
                        {"min_channels", slot.min_channels},
                        {"max_channels", slot.max_channels},
                        {"meaning", slot.meaning}});
    return list;
}

// A bound as a JSON number (JSON has no infinity: an open-ended one is null).
Json bound(double v)
{
    return std::isfinite(v) ? Json(v) : Json(nullptr);
}

}  // namespace

std::string operations_json()
{
    Json ops = Json::array();
    for (const OperationInfo& op : operations()) {
        Json modifiers = Json::array();
        for (const ModifierInfo& m : op.modifiers) {
            Json j;
            j["name"] = m.name;
            j["type"] = type_name(m.type);
            j["choices"] = m.choices;
            if (m.type == ModifierType::Integer || m.type == ModifierType::Number) {
                j["min"] = bound(m.min);
                j["max"] = bound(m.max);
                j["min_open"] = m.min_open;
                j["max_open"] = m.max_open;
                j["unit"] = m.unit;
            }
            j["default"] = m.default_value;
            j["applies_to"] = m.applies_to;
            j["meaning"] = m.meaning;
            modifiers.push_back(std::move(j));
        }
        ops.push_back({{"name", op.name},
                       {"summary", op.summary},
                       {"inputs", json_slots(op.inputs)},
                       {"outputs", json_slots(op.outputs)},
                       {"modifiers", std::move(modifiers)}});
    }
    const Json doc = {{"abi_version", RELIEF_ABI_VERSION}, {"operations", std::move(ops)}};
    return doc.dump(2) + "\n";
}

}  // namespace relief
