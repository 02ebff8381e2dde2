// SPDX-License-Identifier: Apache-2.0
#pragma once
// The OpenCL devices relief can run on.
#include <string>
#include <vector>

#include "relief/export.h"

namespace relief {

struct DeviceDescription {
    std::string id;  // "<platform>:<device>", what Execution::device accepts
    std::string platform;
    std::string platform_version;  // "OpenCL 3.0 PoCL 3.1 ..."
    std::string name;
    bool is_gpu = false;
    bool has_fp64 = false;
};

// Every OpenCL device; empty (and geterror() set) when there is none.
RELIEF_API std::vector<DeviceDescription> list_devices();

// What this relief runs on, one line each, for --version and bug reports:
// "OpenImageIO 2.4.7", "OpenColorIO 2.1.2", "VkFFT 1.2.26", then each
// OpenCL platform, "OpenCL platform 0: Portable Computing Language (OpenCL
// 3.0 PoCL 3.1 ...)", or why there is none.
RELIEF_API std::vector<std::string> component_versions();

// Seconds this process has spent, since it started, setting up compute
// rather than computing: opening the device (platforms, context, queue),
// building relief's kernels, and planning FFTs (VkFFT builds kernels of its
// own). The first operation on a device pays most of it; later operations
// in the same process (a --batch) reuse the device and its programs.
// `prepared`: the seconds prepare() spent, apart from the rest (it may have
// run beside other work).
struct SetupTimes {
    double device = 0.0;
    double programs = 0.0;
    double plans = 0.0;
    double prepared = 0.0;
};
RELIEF_API SetupTimes setup_times();

// Sets up now what a height() of a width x height map on `device` (as
// Execution::device names it) needs first: the device, its kernels and the
// FFT plans of that size. Operations do this themselves when needed; a
// front end that knows the size before it has the pixels calls prepare() on
// a thread of its own, so that the set-up overlaps reading the map (the
// command line does). Errors are not reported here: the operation meets
// them again and reports them. Safe to call concurrently with operations.
RELIEF_API void prepare(const std::string& device, int width, int height);

// Why relief's settings in the environment cannot be used ("" when they
// can): a malformed RELIEF_MEMORY_LIMIT. Operations refuse such a call
// themselves; a front end asks once at start-up, to refuse the run as a
// usage error before any work (the command line exits 2).
RELIEF_API std::string environment_problem();

}  // namespace relief
