#pragma once
// Exceptions thrown by the host layer; the plugin turns them into geterror().
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
    KernelBuildError(const std::string& what, std::string log)
        : Error(what), log_(std::move(log)) {}
    const std::string& log() const { return log_; }

private:
    std::string log_;
};

} // namespace relief::host
