// SPDX-License-Identifier: Apache-2.0
#include "error_state.h"

#include "relief/errors.h"

namespace relief {

namespace {
thread_local std::string last_error;
}

void detail::set_error(const std::string& message)
{
    last_error = message;
}

std::string geterror(bool clear)
{
    std::string e = last_error;
    if (clear)
        last_error.clear();
    return e;
}

}  // namespace relief
