// SPDX-License-Identifier: Apache-2.0
#include "text_file.h"

#include <stdexcept>

#include "relief/errors.h"
#include "relief/output_files.h"

namespace relief::cli {

void write_text_atomically(const std::string& path, const std::string& text, const std::string& what)
{
    if (!relief::write_text_file(path, text))
        throw std::runtime_error(what + ": " + relief::geterror());
}

}  // namespace relief::cli
