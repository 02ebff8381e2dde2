#include "compute_context.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "binary_cache.h"
#include "errors.h"
#include "kernel_sources.h"
#include "opencl_context.h"
#include "plan_cache.h"
#include "setup_times.h"

namespace relief::host {

std::string kernel_source(const std::string& name)
{
    if (const char* dir = std::getenv("RELIEF_KERNEL_DIR"); dir && *dir) {
        std::ifstream in(std::string(dir) + "/" + name, std::ios::binary);
        if (!in)
            throw Error("RELIEF_KERNEL_DIR is set but " + std::string(dir) + "/" + name +
                        " cannot be read");
        std::ostringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }
    for (const auto& s : embedded_kernel_sources())
        if (s.name == name)
            return s.text;
    throw Error("no embedded kernel named " + name);
}

std::string DeviceInfo::describe() const
{
    std::ostringstream ss;
    ss << platform_index << ":" << device_index << " " << platform << " / " << name
       << (is_gpu ? " (GPU)" : " (CPU/other)");
    return ss.str();
}

namespace {

std::vector<cl::Platform> platforms()
{
    std::vector<cl::Platform> list;
    try {
        cl::Platform::get(&list);
    } catch (const cl::Error&) {
        list.clear();  // CL_PLATFORM_NOT_FOUND_KHR: no ICD installed
    }
    return list;
}

// The ICD loader and PoCL initialise on the first enumeration, and that is
// not safe from two threads at once (prepare() runs beside the read).
std::mutex& enumeration_mutex()
{
    static std::mutex m;
    return m;
}

cl::Device device_at(int platform_index, int device_index)
{
    std::lock_guard<std::mutex> lock(enumeration_mutex());
    auto plats = platforms();
    std::vector<cl::Device> devs;
    plats.at(platform_index).getDevices(CL_DEVICE_TYPE_ALL, &devs);
    return devs.at(device_index);
}

} // namespace

std::vector<DeviceInfo> list_devices()
{
    std::lock_guard<std::mutex> lock(enumeration_mutex());
    auto plats = platforms();
    if (plats.empty())
        throw NoDeviceError("no OpenCL platform found (install an OpenCL driver, e.g. the "
                            "Debian package pocl-opencl-icd for the CPU)");
    std::vector<DeviceInfo> out;
    for (std::size_t p = 0; p < plats.size(); ++p) {
        std::vector<cl::Device> devs;
        try {
            plats[p].getDevices(CL_DEVICE_TYPE_ALL, &devs);
        } catch (const cl::Error&) {
            continue;  // CL_DEVICE_NOT_FOUND on this platform
        }
        for (std::size_t d = 0; d < devs.size(); ++d) {
            DeviceInfo info;
            info.platform_index = int(p);
            info.device_index = int(d);
            info.platform = plats[p].getInfo<CL_PLATFORM_NAME>();
            info.name = devs[d].getInfo<CL_DEVICE_NAME>();
            info.is_gpu = (devs[d].getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) != 0;
            info.has_fp64 = devs[d].getInfo<CL_DEVICE_DOUBLE_FP_CONFIG>() != 0;
            out.push_back(info);
        }
    }
    if (out.empty())
        throw NoDeviceError("OpenCL found a platform but no device");
    return out;
}

DeviceInfo choose_device(const std::string& spec)
{
    if (spec != "auto" && spec != "gpu" && spec != "cpu") {
        auto colon = spec.find(':');
        char* end = nullptr;
        long p = -1, d = -1;
        if (colon != std::string::npos && colon > 0 && colon + 1 < spec.size()) {
            p = std::strtol(spec.c_str(), &end, 10);
            if (end != spec.c_str() + colon)
                p = -1;
            d = std::strtol(spec.c_str() + colon + 1, &end, 10);
            if (*end)
                d = -1;
        }
        if (p < 0 || d < 0)
            throw Error("bad device '" + spec +
                        "': expected auto, gpu, cpu or <platform>:<device> (e.g. 0:0)");
        for (const auto& info : list_devices())
            if (info.platform_index == p && info.device_index == d)
                return info;
        throw NoDeviceError("no OpenCL device " + spec);
    }
    auto devices = list_devices();
    for (const auto& info : devices)
        if (info.is_gpu && spec != "cpu")
            return info;
    if (spec == "gpu")
        throw NoDeviceError("no OpenCL GPU device found");
    for (const auto& info : devices)
        if (!info.is_gpu)
            return info;
    return devices.front();
}

std::shared_ptr<ComputeContext> ComputeContext::acquire(const std::string& spec)
{
    static std::mutex mutex;
    static std::map<std::string, std::shared_ptr<ComputeContext>> contexts;
    SetupTimer timer(SetupTimer::Kind::Device);
    // One thread at a time from choosing to creating: a second waits for the
    // context the first is making (device_at enumerates again, too).
    std::lock_guard<std::mutex> lock(mutex);
    DeviceInfo info = choose_device(spec);
    std::string key = std::to_string(info.platform_index) + ":" + std::to_string(info.device_index);
    auto& slot = contexts[key];
    if (!slot)
        slot = std::make_shared<ComputeContext>(info);
    return slot;
}

ComputeContext::ComputeContext(const DeviceInfo& device) : device_(device), impl_(new Impl)
{
    try {
        impl_->device = device_at(device.platform_index, device.device_index);
        impl_->context = cl::Context(impl_->device);
        impl_->queue = cl::CommandQueue(impl_->context, impl_->device);
        impl_->plans = std::make_shared<PlanCache>();
        impl_->max_alloc = std::size_t(impl_->device.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>());
        const cl::Platform platform(impl_->device.getInfo<CL_DEVICE_PLATFORM>());
        impl_->identity = platform.getInfo<CL_PLATFORM_NAME>() + "\n" + platform.getInfo<CL_PLATFORM_VERSION>() +
                          "\n" + impl_->device.getInfo<CL_DEVICE_NAME>() + "\n" +
                          impl_->device.getInfo<CL_DEVICE_VERSION>() + "\n" +
                          impl_->device.getInfo<CL_DRIVER_VERSION>();
    } catch (const cl::Error& e) {
        throw Error("cannot open OpenCL device " + device.describe() + ": " + e.what() +
                    " (error " + std::to_string(e.err()) + ")");
    }
}

ComputeContext::~ComputeContext() = default;

namespace {

std::string mebibytes(std::size_t bytes)
{
    char text[64];
    std::snprintf(text, sizeof text, "%.1f MiB", double(bytes) / (1024.0 * 1024.0));
    return text;
}

// $RELIEF_DEVICE_MAX_ALLOC: a whole number of bytes, or unset.
std::size_t max_alloc_override()
{
    const char* text = std::getenv("RELIEF_DEVICE_MAX_ALLOC");
    if (!text || !*text)
        return 0;
    char* end = nullptr;
    errno = 0;
    const unsigned long long v = std::strtoull(text, &end, 10);
    if (*end || errno || v == 0 || text[0] == '-')
        throw Error(std::string("RELIEF_DEVICE_MAX_ALLOC must be a number of bytes > 0, not '") +
                    text + "'");
    return std::size_t(v);
}

} // namespace

cl::Buffer ComputeContext::Impl::buffer(cl_mem_flags flags, std::size_t bytes,
                                        const std::string& what, const void* host)
{
    const std::size_t limit = buffer_limit();
    if (bytes > limit)
        throw Error(what + " needs a device buffer of " + mebibytes(bytes) +
                    ", more than the device allows in one buffer (" + mebibytes(limit) +
                    (limit < max_alloc ? ", RELIEF_DEVICE_MAX_ALLOC" : ", CL_DEVICE_MAX_MEM_ALLOC_SIZE") +
                    ")");
    return cl::Buffer(context, flags, bytes == 0 ? 1 : bytes, const_cast<void*>(host));
}

std::size_t ComputeContext::Impl::buffer_limit() const
{
    const std::size_t cap = max_alloc_override();
    return cap && cap < max_alloc ? cap : max_alloc;
}

void ComputeContext::build_program(const std::string& file)
{
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->program(file);
}

cl::Program& ComputeContext::Impl::program(const std::string& file, const std::string& options)
{
    std::lock_guard<std::mutex> lock(programs_mutex);
    const std::string key = file + " " + options;
    auto it = programs.find(key);
    if (it != programs.end())
        return it->second;
    SetupTimer timer(SetupTimer::Kind::Programs);
    const std::string source = kernel_source("common.h") + "\n#line 1 \"" + file + "\"\n" +
                               kernel_source(file);
    const std::string build_options = "-cl-std=CL1.2 " + options;
    const std::string cache_key = BinaryCache::key({"program", identity, source, build_options});
    if (const std::optional<std::string> binary = BinaryCache::load(cache_key)) {
        try {
            cl::Program prog(context, {device},
                             cl::Program::Binaries{std::vector<unsigned char>(binary->begin(), binary->end())});
            prog.build({device}, build_options.c_str());
            return programs.emplace(key, prog).first->second;
        } catch (const cl::Error&) {
            // a binary this driver no longer takes: build from source, store anew
        }
    }
    cl::Program prog(context, source);
    try {
        prog.build({device}, build_options.c_str());
    } catch (const cl::Error&) {
        std::string log;
        try {
            log = prog.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device);
        } catch (const cl::Error&) {
        }
        throw KernelBuildError("OpenCL kernel " + file + " failed to build:\n" + log, log);
    }
    try {
        const std::vector<std::vector<unsigned char>> binaries = prog.getInfo<CL_PROGRAM_BINARIES>();
        if (binaries.size() == 1)
            BinaryCache::store(cache_key, std::string(binaries[0].begin(), binaries[0].end()));
    } catch (const cl::Error&) {
        // no binary to keep: the next process builds from source again
    }
    return programs.emplace(key, prog).first->second;
}

} // namespace relief::host
