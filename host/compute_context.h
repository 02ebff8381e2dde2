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
    std::string platform;  // platform name
    std::string name;      // device name
    bool is_gpu = false;
    bool has_fp64 = false;
    std::string describe() const;  // "0:0 NVIDIA CUDA / NVIDIA H100 (GPU)"
};

// Every OpenCL device on every platform. Throws NoDeviceError when OpenCL has
// no platform at all (no ICD installed).
std::vector<DeviceInfo> list_devices();

// Picks a device by spec: "auto" (the first GPU, else the first CPU or other
// device), "gpu", "cpu", or "<platform>:<device>" indices as list_devices()
// numbers them. Throws Error for a malformed spec, NoDeviceError when nothing
// matches.
DeviceInfo choose_device(const std::string& spec);

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

} // namespace relief::host
