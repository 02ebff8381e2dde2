// SPDX-License-Identifier: Apache-2.0
#pragma once
// Exceptions thrown by the host layer; the plugin turns them into geterror().
#include <climits>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace relief::host {

struct Error : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// No OpenCL platform or no device matching the request.
struct NoDeviceError : Error {
    using Error::Error;
};

// A kernel failed to compile; log() is the OpenCL compiler's build log.
struct KernelBuildError : Error {
    KernelBuildError(const std::string& what, std::string log) : Error(what), log_(std::move(log)) {}
    const std::string& log() const { return log_; }

private:
    std::string log_;
};

// A promise the host's callers make broken: the plugin checks every option
// (relief::validate()) before it calls the host, so this is a bug in relief,
// not bad input. `invariant` says what should have held.
struct InternalError : std::logic_error {
    using std::logic_error::logic_error;
};
inline void expects(bool holds, const char* invariant)
{
    if (!holds)
        throw InternalError(std::string("internal error: expected ") + invariant);
}

// The kernels index texels (and padded transform grids, nodes at texel
// corners) with 32-bit ints: a map whose (w + 2) x (h + 2) passes 2^31 - 1
// (46338^2 fits) is refused with the numbers rather than overflowing.
inline void check_index_range(long long w, long long h, const std::string& what)
{
    if ((w + 2) * (h + 2) > (long long)INT_MAX)
        throw Error(what + ": a " + std::to_string(w) + "x" + std::to_string(h) +
                    " map is larger than this version handles ((width + 2) x (height + 2) must "
                    "stay below 2^31, e.g. 46338x46338)");
}

}  // namespace relief::host
