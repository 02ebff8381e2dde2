// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string>

#include "relief/export.h"

namespace relief {

// The error message of the last failed relief call on this thread (empty if
// none); clears it unless clear is false. Like OIIO::geterror().
RELIEF_API std::string geterror(bool clear = true);

}  // namespace relief
