// SPDX-License-Identifier: Apache-2.0
#pragma once
// OpenCL objects behind ComputeContext; included only by host/*.cpp.
#include <CL/opencl.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "device/compute_context.h"
#include "errors.h"
#include "slopes/device_slopes.h"

namespace relief::host {

class PlanCache;  // plan_cache.h

struct ComputeContext::Impl {
    cl::Device device;
    cl::Context context;
    cl::CommandQueue queue;
    std::mutex mutex;           // serialises stage launches
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

    // New buffers without host data are filled with quiet NaNs: on a
    // simulator (Oclgrind), and wherever RELIEF_POISON_BUFFERS=1. A GPU
    // hands out recycled memory, a CPU device fresh zero pages, so a kernel
    // that reads what no kernel wrote shows only on a GPU; with NaNs it
    // shows everywhere, in the result. On Oclgrind it also keeps the
    // uninitialised-value checks right: Oclgrind 21.10 keeps a released
    // buffer's record of what was written and hands it to the next buffer
    // that takes its number, so a new buffer larger than the last one of
    // that number reads as uninitialised past its size, whatever kernels
    // wrote there (tests/portability/reused_buffer.cpp); a host write gives
    // the new buffer a record of its own size.
    bool poison_new_buffers = false;
    bool device_is_simulator = false;
    void poison(cl::Buffer& buffer, std::size_t bytes);

    // Launch limits, from the device's queries: CL_DEVICE_MAX_WORK_GROUP_SIZE
    // and CL_DEVICE_MAX_WORK_ITEM_SIZES, CL_DEVICE_LOCAL_MEM_SIZE; lower when
    // RELIEF_MAX_WORK_GROUP_SIZE or RELIEF_LOCAL_MEM_SIZE (bytes, K suffix
    // allowed) say so, to run the suite as a smaller GPU would.
    std::size_t max_group = 1;
    std::array<std::size_t, 3> max_item_sizes{1, 1, 1};
    std::size_t local_memory = 0;

    // The work-group size for a 1-D launch of `kernel`: the largest power of
    // two up to kPreferredGroup that the device, the kernel
    // (CL_KERNEL_WORK_GROUP_SIZE) and `local_bytes_per_item` bytes of local
    // memory per work-item (beside the kernel's own, CL_KERNEL_LOCAL_MEM_SIZE)
    // allow. Throws Error when not even one work-item fits.
    std::size_t group_size(const cl::Kernel& kernel, std::size_t local_bytes_per_item = 0);
    // A 2-D group for `kernel` no larger than `largest` in x and y: halves
    // the larger side until the device and the kernel allow it.
    cl::NDRange group_shape(const cl::Kernel& kernel, std::size_t largest_x, std::size_t largest_y);
    // Enqueues `kernel` over `items` work-items (1-D) in groups of
    // group_size(kernel, local_bytes_per_item): the global size is rounded up
    // (no non-uniform groups in OpenCL 1.2; kernels bound-check). Returns
    // the group size used.
    std::size_t launch(cl::Kernel& kernel, std::size_t items, std::size_t local_bytes_per_item = 0);
    // launch() over `items` in parts of at least `per_part` work-items (a
    // multiple of the group size; get_global_id counts on from part to
    // part), each finished before the next is queued: one long pass stays
    // within reach of a cancel (asked before each part) and of a GPU's
    // watchdog.
    void launch_in_parts(cl::Kernel& kernel, std::size_t items, std::size_t per_part);

    // clEnqueueFillBuffer by a kernel of relief's (kernels/device.cl): the
    // `bytes` from `offset` on set to `pattern` repeated (1, 4 or 8 bytes;
    // offset and bytes multiples of its size). Oclgrind's uninitialised-value
    // checks do not see the API's fills (tests/portability/fill_buffer.cpp).
    void fill(cl::Buffer& buffer, const void* pattern, std::size_t pattern_size, std::size_t offset,
              std::size_t bytes);
    template <class T>
    void fill(cl::Buffer& buffer, T pattern, std::size_t offset, std::size_t bytes)
    {
        fill(buffer, &pattern, sizeof(T), offset, bytes);
    }

    // How many loop iterations a work-item may run in all before the device
    // cuts its loops short without an error (Mesa's llvmpipe: about 65535);
    // UINT64_MAX where a probe of 2^21 found no limit; RELIEF_LOOP_LIMIT
    // lowers it (tests). Probed on first use (kernels/device.cl). The caller
    // holds `mutex`.
    std::uint64_t loop_limit();
    std::uint64_t loop_limit_ = 0;        // 0: not probed yet
    std::uint64_t loop_cap = UINT64_MAX;  // RELIEF_LOOP_LIMIT
    // Whether a work-item may loop `iterations` times in all: up to
    // kLoopsAnyDevice (and RELIEF_LOOP_LIMIT) without a probe, else up to
    // loop_limit().
    bool loops_fit(std::uint64_t iterations)
    {
        return iterations <= std::min(kLoopsAnyDevice, loop_cap) || iterations <= loop_limit();
    }
    static constexpr std::uint64_t kLoopsAnyDevice = 32768;

    // The built program for kernels/<file> (common.h prepended), compiled
    // with extra `options` (e.g. "-DRELIEF_FP64"); cached per file + options.
    cl::Program& program(const std::string& file, const std::string& options = "")
    {
        return program(std::vector<std::string>{file}, options);
    }
    // The same for a stage whose kernels fill several files (the
    // correction's), joined in this order after common.h.
    cl::Program& program(const std::vector<std::string>& files, const std::string& options = "");
};

struct DeviceSlopes::Impl {
    cl::Buffer buffer;  // cl_float2 per texel
};

// Held around every program's creation and build in the process, relief's
// and VkFFT's. OpenCL says these are safe on two threads at once, but
// Oclgrind 21.10's LLVM crashes when two run together, as they do when
// prepare() sets up beside the read (tests/portability/concurrent_build.cpp;
// prepare() also does nothing on a simulator). Programs from a binary take
// milliseconds; only a cold process's first builds lose their overlap.
std::mutex& compiler_mutex();

// The largest work-group relief asks for: a GPU's usual choice (several
// warps or wavefronts per group); devices and kernels that allow less get
// less (ComputeContext::Impl::group_size).
constexpr std::size_t kPreferredGroup = 256;

// n rounded up to a multiple of `group`: global sizes must be multiples of
// the work-group size (PoCL and many OpenCL 1.2 devices have no
// non-uniform work-groups); kernels bound-check.
inline std::size_t round_up(std::size_t n, std::size_t group)
{
    return (n + group - 1) / group * group;
}

// Sets `kernel`'s arguments `first`, `first` + 1, ... to `args`, in order:
// the ones that change between launches of a kernel whose others are set.
template <class... Args>
void set_args_at(cl::Kernel& kernel, cl_uint first, const Args&... args)
{
    cl_uint index = first;
    (kernel.setArg(index++, args), ...);
}

// Sets `kernel`'s arguments 0, 1, 2 ... to `args`, in order: one call in
// place of a hand-numbered setArg per argument.
template <class... Args>
void set_args(cl::Kernel& kernel, const Args&... args)
{
    set_args_at(kernel, 0, args...);
}

#if defined(CL_HPP_ENABLE_EXCEPTIONS)  // (host/*.cpp; tests include this header without)
// The host's error for an OpenCL call that failed in `stage` ("the fast
// ray" stage): the call, its error code, the stage.
inline Error opencl_error(const std::string& stage, const cl::Error& e)
{
    return Error("OpenCL error in the " + stage + " stage: " + e.what() + " (" + std::to_string(e.err()) +
                 ")");
}
#endif

}  // namespace relief::host
