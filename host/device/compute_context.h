// SPDX-License-Identifier: Apache-2.0
#pragma once
// Device discovery and choice, and one OpenCL context + queue + program cache
// per chosen device. This header has no OpenCL types: the plugin includes it.
#include <memory>
#include <string>
#include <vector>

namespace relief::host {

struct DeviceInfo {
    int platform_index = -1;
    int device_index = -1;
    std::string platform;          // platform name
    std::string platform_version;  // CL_PLATFORM_VERSION: "OpenCL 3.0 PoCL 3.1 ..."
    std::string name;              // device name
    bool is_gpu = false;
    bool is_cpu = false;
    // A simulator (Oclgrind) rather than hardware: it reports itself as a
    // GPU but runs kernels thousands of times slower, so `auto` and `gpu`
    // take one only when nothing else matches.
    bool simulator = false;
    bool has_fp64 = false;                 // cl_khr_fp64
    unsigned long long global_memory = 0;  // CL_DEVICE_GLOBAL_MEM_SIZE
    // "0:0 NVIDIA CUDA / NVIDIA H100 (GPU, fp64)"; the part in brackets says
    // the device type and which accumulation path the kernels take.
    std::string describe() const;
};

// RELIEF_FP64: "auto" (unset: double accumulations where the device has
// cl_khr_fp64), "on" (the same, and a device without fp64 is refused) or
// "off" (float paths on every device: Kahan sums, re-anchored prefix sums).
// Throws Error for any other value.
enum class Fp64Policy { Auto, On, Off };
Fp64Policy fp64_policy();

// Every OpenCL device on every platform, in the platforms' and devices' own
// order. Throws NoDeviceError when OpenCL has no platform at all (no ICD).
std::vector<DeviceInfo> list_devices();

// Picks a device by spec:
//   "auto"  RELIEF_DEVICE when that is set (any spec below but auto), else
//           the best-ranked device (device_rank());
//   "gpu"   the best-ranked GPU; NoDeviceError when there is none;
//   "cpu"   the best-ranked CPU device; NoDeviceError when there is none;
//   "P:D"   platform P's device D, as list_devices() numbers them.
// Throws Error for a malformed spec, NoDeviceError when nothing matches.
DeviceInfo choose_device(const std::string& spec);

// How `auto` orders devices, best first: hardware GPUs, then CPUs, then
// other devices (accelerators), then simulators; within each, devices with
// fp64 first, then more global memory, then list order. So PoCL's CPU
// device (fp64) comes before Rusticl's llvmpipe (no fp64), and a real GPU
// before both; Oclgrind, which calls itself a GPU, only when it is alone
// (as under `oclgrind relief ...`, which hides every other platform).
// Returns list_devices() sorted so.
std::vector<DeviceInfo> rank_devices(std::vector<DeviceInfo> devices);

class ComputeContext {
public:
    // The shared context for a device spec; created on first use and reused
    // so that kernels are built once per process and device.
    static std::shared_ptr<ComputeContext> acquire(const std::string& spec);

    explicit ComputeContext(const DeviceInfo& device);
    ~ComputeContext();
    ComputeContext(const ComputeContext&) = delete;
    ComputeContext& operator=(const ComputeContext&) = delete;

    const DeviceInfo& device() const { return device_; }
    // Whether kernels accumulate in double on this device now: it has fp64
    // and RELIEF_FP64 is not "off" (read at each call, so a process can
    // switch; "on" without fp64 throws Error).
    bool fp64() const;

    // Builds (once) the program made of common.h + kernels/<file>; throws
    // KernelBuildError carrying the compiler's log on failure. Exposed for
    // tests; stages use it through opencl_context.h.
    void build_program(const std::string& file);

    struct Impl;  // OpenCL objects, see opencl_context.h
    Impl& impl() { return *impl_; }

private:
    DeviceInfo device_;
    std::unique_ptr<Impl> impl_;
};

}  // namespace relief::host
