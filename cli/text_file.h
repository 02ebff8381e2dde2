// SPDX-License-Identifier: Apache-2.0
#pragma once
// Small text outputs of the command line (the --report file).
#include <string>

namespace relief::cli {

// Writes `text` to `path` as relief::write_text_file does (an exclusive
// temporary file renamed over `path` when complete: a failure leaves an
// existing file as it was and no temporary behind). Throws
// std::runtime_error: "WHAT: cannot write 'PATH': the system's reason".
void write_text_atomically(const std::string& path, const std::string& text, const std::string& what);

}  // namespace relief::cli
