#pragma once
// The OpenCL devices relief can run on.
#include <string>
#include <vector>

#include "relief/export.h"

namespace relief {

struct DeviceDescription {
    std::string id;        // "<platform>:<device>", what Execution::device accepts
    std::string platform;
    std::string name;
    bool is_gpu = false;
    bool has_fp64 = false;
};

// Every OpenCL device; empty (and geterror() set) when there is none.
RELIEF_API std::vector<DeviceDescription> list_devices();

} // namespace relief
