#pragma once
// OpenCL objects behind ComputeContext; included only by host/*.cpp.
#include <CL/opencl.hpp>

#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "compute_context.h"
#include "slope_stage.h"

namespace relief::host {

class PlanCache;  // plan_cache.h

struct ComputeContext::Impl {
    cl::Device device;
    cl::Context context;
    cl::CommandQueue queue;
    std::mutex mutex;  // serialises stage launches
    std::mutex programs_mutex;  // guards programs (built also by prepare_height)
    std::map<std::string, cl::Program> programs;
    // FFT/DCT plans kept for the next map of the same size (plan_cache.h).
    std::shared_ptr<PlanCache> plans;
    // The largest buffer to allocate: CL_DEVICE_MAX_MEM_ALLOC_SIZE, or less
    // when $RELIEF_DEVICE_MAX_ALLOC (bytes) says so (a shared device; tests).
    std::size_t max_alloc = 0;
    // What a compiled binary depends on besides its source: platform and
    // device names and versions (a driver update invalidates binaries).
    std::string identity;

    // A buffer of `bytes` (copied from `host` when given), or Error with the
    // numbers when it is larger than max_alloc; `what` names it for users.
    cl::Buffer buffer(cl_mem_flags flags, std::size_t bytes, const std::string& what,
                      const void* host = nullptr);
    std::size_t buffer_limit() const;  // max_alloc, or the override

    // The built program for kernels/<file> (common.h prepended), compiled
    // with extra `options` (e.g. "-DRELIEF_FP64"); cached per file + options.
    cl::Program& program(const std::string& file, const std::string& options = "");
};

struct DeviceSlopes::Impl {
    cl::Buffer buffer;  // cl_float2 per texel
};

// Global sizes must be multiples of the work-group size: PoCL and many
// OpenCL 1.2 devices have no non-uniform work-groups. Kernels bound-check.
constexpr std::size_t kGroupSize = 64;
inline std::size_t padded(std::size_t n)
{
    return (n + kGroupSize - 1) / kGroupSize * kGroupSize;
}

} // namespace relief::host
