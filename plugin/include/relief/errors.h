#pragma once
#include <string>

namespace relief {

// The error message of the last failed relief call on this thread (empty if
// none); clears it unless clear is false. Like OIIO::geterror().
std::string geterror(bool clear = true);

} // namespace relief
