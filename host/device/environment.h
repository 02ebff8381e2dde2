// SPDX-License-Identifier: Apache-2.0
#pragma once
// Numbers from environment variables (RELIEF_MEMORY_LIMIT, the launch
// limits of a smaller device for tests, ...), refused with the variable's
// name when malformed. No OpenCL types here.
#include <cstdint>

namespace relief::host {

// The size in environment variable `name`: "<n>", or with a K, M, G or T
// suffix (powers of 1024); 0 when unset or empty. Throws Error naming the
// variable for anything else.
std::uint64_t size_from_environment(const char* name);

// A whole number > 0 in environment variable `name`; 0 when unset or empty.
// Throws Error naming the variable (and the number's `unit`, e.g. "bytes",
// when given) for anything else.
std::uint64_t count_from_environment(const char* name, const char* unit = nullptr);

}  // namespace relief::host
