// SPDX-License-Identifier: Apache-2.0
#pragma once
// Numbers from environment variables (RELIEF_MEMORY_LIMIT, the launch
// limits of a smaller device for tests, ...), refused with the variable's
// name when malformed. No OpenCL types here.
#include <cstdint>
#include <string>

namespace relief::host {

// A size from the environment as it was given.
struct SizeSetting {
    std::uint64_t bytes = 0;  // 0: unset or empty
    bool binary = false;      // given in powers of 1024 (K, KiB, ...)
    std::string text;         // the variable's text
};

// The size in environment variable `name`: "<n>" bytes; with K, M, G or T
// (either case) alone or followed by "iB", powers of 1024; followed by "B"
// (kB, MB, GB, TB), powers of 1000. Throws Error naming the variable for
// anything else.
SizeSetting size_setting_from_environment(const char* name);

// Its bytes; 0 when unset or empty.
std::uint64_t size_from_environment(const char* name);

// A whole number > 0 in environment variable `name`; 0 when unset or empty.
// Throws Error naming the variable (and the number's `unit`, e.g. "bytes",
// when given) for anything else.
std::uint64_t count_from_environment(const char* name, const char* unit = nullptr);

}  // namespace relief::host
