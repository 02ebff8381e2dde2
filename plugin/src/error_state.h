// SPDX-License-Identifier: Apache-2.0
#pragma once
// The per-thread error behind relief::geterror().
#include <string>

namespace relief::detail {

void set_error(const std::string& message);

}  // namespace relief::detail
