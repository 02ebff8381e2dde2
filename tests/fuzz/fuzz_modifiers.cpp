// Fuzz target: an operation's modifiers ("key=value:key=value"). The first
// byte picks the operation from the table, the rest is the text. A text
// that parses must write out in full (modifier_text, what --update's digest
// hashes) to a text that, less the modifiers of the other height method
// (which the parser refuses beside this one's), parses to the same call.
#include <cstddef>
#include <cstdint>
#include <string>

#include "relief/errors.h"
#include "relief/operations.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    if (size == 0)
        return 0;
    const auto& table = relief::operations();
    const std::string& operation = table[data[0] % table.size()].name;
    const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
    relief::OperationCall call;
    if (!relief::parse_modifiers(call, operation, text)) {
        if (relief::geterror().empty())
            __builtin_trap();  // a refusal says why
        return 0;
    }
    const std::string full = relief::modifier_text(call);
    // The values in table order: modifier i's runs from "name_i=" to
    // ":name_{i+1}=" (a value may hold colons: fix=height:H0:DH).
    const auto& modifiers = relief::find_operation(operation)->modifiers;
    const bool rays = operation == "height" && call.height.method == relief::HeightMethod::Rays;
    std::string written;
    std::size_t from = 0;
    for (std::size_t i = 0; i < modifiers.size(); ++i) {
        const std::string key = modifiers[i].name + "=";
        if (full.compare(from, key.size(), key) != 0)
            __builtin_trap();  // every modifier is written, in the table's order
        const std::size_t start = from + key.size();
        const std::size_t end =
            i + 1 < modifiers.size() ? full.find(":" + modifiers[i + 1].name + "=", start) : full.size();
        if (end == std::string::npos)
            __builtin_trap();
        from = end + 1;
        if (operation == "height" && modifiers[i].applies_to == (rays ? "method=poisson" : "method=rays"))
            continue;  // the other method's: refused beside this one's
        written += (written.empty() ? "" : ":") + key + full.substr(start, end - start);
    }
    relief::OperationCall again;
    if (!relief::parse_modifiers(again, operation, written))
        __builtin_trap();  // the written-out call does not parse
    again.operation = call.operation;
    if (relief::modifier_text(again) != full)
        __builtin_trap();  // nor does it say the same
    return 0;
}
