#pragma once
// The operation table's checks, for the operations' own option checks: a
// value set through the C++ option structs is held to the same types and
// ranges as one typed on the command line.
#include <string>

#include "relief/operations.h"

namespace relief::detail {

// Throws std::invalid_argument ("rays=0 must be an integer in [1, 4096]")
// when a modifier's value in call (the member named by `operation`) is
// outside the table's range or choices.
void check_modifier_values(const std::string& operation, const OperationCall& call);

} // namespace relief::detail
