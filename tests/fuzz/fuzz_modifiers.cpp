// Fuzz target: an operation's modifiers ("key=value:key=value"). The first
// byte picks the operation from the table, the rest is the text. A text
// that parses must write out in full (modifier_text) to a text that parses
// to the same call: what --update's digest and relief:parameters rely on.
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
    relief::OperationCall again;
    if (!relief::parse_modifiers(again, operation, full))
        __builtin_trap();  // the written-out call does not parse
    if (relief::modifier_text(again) != full)
        __builtin_trap();  // nor does it say the same
    return 0;
}
