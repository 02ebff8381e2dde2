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

// Seconds this process has spent, since it started, setting up compute
// rather than computing: opening the device (platforms, context, queue),
// building relief's kernels, and planning FFTs (VkFFT builds kernels of its
// own). The first operation on a device pays most of it; later operations
// in the same process (a --batch) reuse the device and its programs.
struct SetupTimes {
    double device = 0.0;
    double programs = 0.0;
    double plans = 0.0;
};
RELIEF_API SetupTimes setup_times();

} // namespace relief
