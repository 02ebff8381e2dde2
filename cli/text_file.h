#pragma once
// Small text outputs of the command line (the --report file).
#include <string>

namespace relief::cli {

// Writes `text` to `path` through a temporary file in the same folder,
// renamed over `path` only when complete: a failure (a full disk) leaves
// an existing file as it was and no temporary behind. Throws
// std::runtime_error naming `what` and the path.
void write_text_atomically(const std::string& path, const std::string& text, const std::string& what);

} // namespace relief::cli
