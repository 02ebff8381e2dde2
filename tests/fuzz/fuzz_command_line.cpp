// Fuzz target: the command line, as a --batch manifest line reaches it.
// The bytes are one line: split into words as a shell would, expanded
// (--frames, <UDIM>) and parsed. A malformed line must come back as a
// UsageError (exit 2, one line of text); anything else escaping, a crash
// or a sanitizer report is a bug.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "batch.h"
#include "command_line.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string line(reinterpret_cast<const char*>(data), size);
    try {
        const std::vector<std::string> words = relief::cli::split_words(line);
        const auto expanded = relief::cli::expand_names(words);
        if (expanded.empty())
            __builtin_trap();  // expand_names returns at least the arguments
        relief::cli::Program p = relief::cli::parse_command_line(expanded.front(), false);
        (void)p;
    } catch (const relief::cli::UsageError& e) {
        if (!*e.what())
            __builtin_trap();  // a refusal says why
    }
    return 0;
}
