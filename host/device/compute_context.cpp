// SPDX-License-Identifier: Apache-2.0
#include "device/compute_context.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "device/binary_cache.h"
#include "device/cancel.h"
#include "errors.h"
#include "device/kernel_sources.h"
#include "device/environment.h"
#include "device/opencl_context.h"
#include "fft/plan_cache.h"
#include "device/setup_times.h"

namespace relief::host {

std::string kernel_source(const std::string& name)
{
    if (const char* dir = std::getenv("RELIEF_KERNEL_DIR"); dir && *dir) {
        std::ifstream in(std::string(dir) + "/" + name, std::ios::binary);
        if (!in)
            throw Error("RELIEF_KERNEL_DIR is set but " + std::string(dir) + "/" + name + " cannot be read");
        std::ostringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }
    for (const auto& s : embedded_kernel_sources())
        if (s.name == name)
            return s.text;
    throw Error("no embedded kernel named " + name);
}

Fp64Policy fp64_policy()
{
    const char* text = std::getenv("RELIEF_FP64");
    if (!text || !*text || std::string(text) == "auto")
        return Fp64Policy::Auto;
    if (std::string(text) == "on")
        return Fp64Policy::On;
    if (std::string(text) == "off")
        return Fp64Policy::Off;
    throw Error(std::string("RELIEF_FP64 must be auto, on or off, not '") + text + "'");
}

std::string DeviceInfo::describe() const
{
    const Fp64Policy policy = fp64_policy();
    std::ostringstream ss;
    ss << platform_index << ":" << device_index << " " << platform << " / " << name << " ("
       << (simulator ? "simulator"
           : is_gpu  ? "GPU"
           : is_cpu  ? "CPU"
                     : "other")
       << ", ";
    if (!has_fp64)
        ss << "float: no fp64";
    else if (policy == Fp64Policy::Off)
        ss << "float: RELIEF_FP64=off";
    else
        ss << "fp64";
    ss << ")";
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

}  // namespace

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
            info.platform_version = plats[p].getInfo<CL_PLATFORM_VERSION>();
            info.name = devs[d].getInfo<CL_DEVICE_NAME>();
            const cl_device_type type = devs[d].getInfo<CL_DEVICE_TYPE>();
            info.is_gpu = (type & CL_DEVICE_TYPE_GPU) != 0;
            info.is_cpu = (type & CL_DEVICE_TYPE_CPU) != 0;
            info.simulator = info.platform.find("Oclgrind") != std::string::npos;
            info.has_fp64 = devs[d].getInfo<CL_DEVICE_EXTENSIONS>().find("cl_khr_fp64") != std::string::npos;
            info.global_memory = devs[d].getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
            out.push_back(info);
        }
    }
    if (out.empty())
        throw NoDeviceError("OpenCL found a platform but no device");
    return out;
}

std::vector<DeviceInfo> rank_devices(std::vector<DeviceInfo> devices)
{
    const auto tier = [](const DeviceInfo& d) { return d.simulator ? 3 : d.is_gpu ? 0 : d.is_cpu ? 1 : 2; };
    std::stable_sort(devices.begin(), devices.end(), [&](const DeviceInfo& a, const DeviceInfo& b) {
        if (tier(a) != tier(b))
            return tier(a) < tier(b);
        if (a.has_fp64 != b.has_fp64)
            return a.has_fp64;
        return a.global_memory > b.global_memory;
    });
    return devices;
}

DeviceInfo choose_device(const std::string& requested)
{
    std::string spec = requested;
    if (spec == "auto") {
        // RELIEF_DEVICE: what `auto` means for this process (a farm node's
        // GPU; the test suite's device, RELIEF_TEST_DEVICE).
        if (const char* env = std::getenv("RELIEF_DEVICE"); env && *env && std::string(env) != "auto") {
            spec = env;
            try {
                return choose_device(spec);
            } catch (const NoDeviceError& e) {
                throw NoDeviceError(std::string(e.what()) + " (RELIEF_DEVICE=" + spec + ")");
            } catch (const Error& e) {
                throw Error(std::string(e.what()) + " (RELIEF_DEVICE)");
            }
        }
    }
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
        const std::vector<DeviceInfo> devices = list_devices();
        std::string here;
        for (const auto& info : devices) {
            if (info.platform_index == p && info.device_index == d)
                return info;
            here += (here.empty() ? "" : "; ") + info.describe();
        }
        // (the numbers there are, as --list-devices prints them)
        throw NoDeviceError("no OpenCL device " + spec + "; the devices here: " + here);
    }
    const auto ranked = rank_devices(list_devices());
    for (const auto& info : ranked)
        if (spec == "auto" || (spec == "gpu" && info.is_gpu) || (spec == "cpu" && info.is_cpu))
            return info;
    throw NoDeviceError("no OpenCL " + std::string(spec == "gpu" ? "GPU" : "CPU") + " device found");
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
        // A bad RELIEF_FP64, or "on" for a device without fp64, is refused
        // before anything runs.
        fp64();
        impl_->device = device_at(device.platform_index, device.device_index);
        impl_->context = cl::Context(impl_->device);
        impl_->queue = cl::CommandQueue(impl_->context, impl_->device);
        impl_->plans = std::make_shared<PlanCache>();
        impl_->max_alloc = std::size_t(impl_->device.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>());
        const char* poison = std::getenv("RELIEF_POISON_BUFFERS");
        if (poison && *poison && std::string(poison) != "0" && std::string(poison) != "1")
            throw Error(std::string("RELIEF_POISON_BUFFERS must be 0 or 1, not '") + poison + "'");
        impl_->device_is_simulator = device.simulator;
        impl_->poison_new_buffers = device.simulator ? !(poison && std::string(poison) == "0")
                                                     : (poison && std::string(poison) == "1");
        impl_->max_group = impl_->device.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>();
        const std::vector<std::size_t> sizes = impl_->device.getInfo<CL_DEVICE_MAX_WORK_ITEM_SIZES>();
        for (std::size_t i = 0; i < 3; ++i)
            impl_->max_item_sizes[i] = i < sizes.size() ? sizes[i] : 1;
        impl_->local_memory = std::size_t(impl_->device.getInfo<CL_DEVICE_LOCAL_MEM_SIZE>());
        if (const std::uint64_t cap = count_from_environment("RELIEF_MAX_WORK_GROUP_SIZE"); cap)
            impl_->max_group = std::min<std::size_t>(impl_->max_group, cap);
        if (const std::uint64_t cap = count_from_environment("RELIEF_LOOP_LIMIT"); cap)
            impl_->loop_cap = cap;
        if (const std::uint64_t cap = size_from_environment("RELIEF_LOCAL_MEM_SIZE"); cap)
            impl_->local_memory = std::min<std::size_t>(impl_->local_memory, cap);
        const cl::Platform platform(impl_->device.getInfo<CL_DEVICE_PLATFORM>());
        impl_->identity =
            platform.getInfo<CL_PLATFORM_NAME>() + "\n" + platform.getInfo<CL_PLATFORM_VERSION>() + "\n" +
            impl_->device.getInfo<CL_DEVICE_NAME>() + "\n" + impl_->device.getInfo<CL_DEVICE_VERSION>() +
            "\n" + impl_->device.getInfo<CL_DRIVER_VERSION>();
    } catch (const cl::Error& e) {
        throw Error("cannot open OpenCL device " + device.describe() + ": " + e.what() + " (error " +
                    std::to_string(e.err()) + ")");
    }
}

ComputeContext::~ComputeContext() = default;

bool ComputeContext::fp64() const
{
    const Fp64Policy policy = fp64_policy();
    if (policy == Fp64Policy::On && !device_.has_fp64)
        throw Error("RELIEF_FP64=on, but " + device_.describe() + " has no fp64 (cl_khr_fp64)");
    return device_.has_fp64 && policy != Fp64Policy::Off;
}

namespace {

std::string mebibytes(std::size_t bytes)
{
    char text[64];
    std::snprintf(text, sizeof text, "%.1f MiB", double(bytes) / (1024.0 * 1024.0));
    return text;
}

}  // namespace

cl::Buffer ComputeContext::Impl::buffer(cl_mem_flags flags, std::size_t bytes, const std::string& what,
                                        const void* host)
{
    const std::size_t limit = buffer_limit();
    if (bytes > limit)
        throw Error(what + " needs a device buffer of " + mebibytes(bytes) +
                    ", more than the device allows in one buffer (" + mebibytes(limit) +
                    (limit < max_alloc ? ", RELIEF_DEVICE_MAX_ALLOC" : ", CL_DEVICE_MAX_MEM_ALLOC_SIZE") +
                    ")");
    cl::Buffer b(context, flags, bytes == 0 ? 1 : bytes, const_cast<void*>(host));
    if (poison_new_buffers && !host && bytes > 0)
        poison(b, bytes);
    return b;
}

void ComputeContext::Impl::poison(cl::Buffer& b, std::size_t bytes)
{
    // Quiet NaNs written from the host: a kernel that reads an element no
    // kernel wrote then carries NaN into its result. On a simulator in one
    // write (Oclgrind records a host write's extent from its start, and
    // maps there are small), elsewhere a block at a time.
    constexpr cl_uint kQuietNan = 0x7fc00000u;
    if (device_is_simulator) {
        const std::vector<cl_uint> nans((bytes + 3) / 4, kQuietNan);
        queue.enqueueWriteBuffer(b, CL_TRUE, 0, bytes, nans.data());
        return;
    }
    static const std::vector<cl_uint> nans(std::size_t(1) << 18, kQuietNan);
    const std::size_t block = sizeof(cl_uint) * nans.size();
    for (std::size_t at = 0; at < bytes; at += block)
        queue.enqueueWriteBuffer(b, CL_FALSE, at, std::min(block, bytes - at), nans.data());
    queue.finish();
}

std::size_t ComputeContext::Impl::buffer_limit() const
{
    const std::size_t cap = std::size_t(count_from_environment("RELIEF_DEVICE_MAX_ALLOC", "bytes"));
    return cap && cap < max_alloc ? cap : max_alloc;
}

void ComputeContext::build_program(const std::string& file)
{
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->program(file);
}

std::size_t ComputeContext::Impl::group_size(const cl::Kernel& kernel, std::size_t local_bytes_per_item)
{
    std::size_t limit = std::min({kPreferredGroup, max_group, max_item_sizes[0]});
    limit = std::min<std::size_t>(limit, kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device));
    const std::size_t own = std::size_t(kernel.getWorkGroupInfo<CL_KERNEL_LOCAL_MEM_SIZE>(device));
    std::size_t g = 1;
    while (2 * g <= limit && own + 2 * g * local_bytes_per_item <= local_memory)
        g *= 2;
    if (own + g * local_bytes_per_item > local_memory)
        throw Error("a kernel needs " + std::to_string(own + local_bytes_per_item) +
                    " bytes of local memory per work-item, more than the device's " +
                    std::to_string(local_memory));
    return g;
}

cl::NDRange ComputeContext::Impl::group_shape(const cl::Kernel& kernel, std::size_t x, std::size_t y)
{
    const std::size_t limit =
        std::min<std::size_t>(max_group, kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device));
    while (x > 1 || y > 1) {
        if (x * y <= limit && x <= max_item_sizes[0] && y <= max_item_sizes[1])
            break;
        if (x >= y)
            x = (x + 1) / 2;
        else
            y = (y + 1) / 2;
    }
    return cl::NDRange(x, y);
}

std::size_t ComputeContext::Impl::launch(cl::Kernel& kernel, std::size_t items,
                                         std::size_t local_bytes_per_item)
{
    stop_if_cancelled();
    const std::size_t g = group_size(kernel, local_bytes_per_item);
    queue.enqueueNDRangeKernel(kernel, cl::NullRange,
                               cl::NDRange(round_up(std::max<std::size_t>(items, 1), g)), cl::NDRange(g));
    return g;
}

void ComputeContext::Impl::launch_in_parts(cl::Kernel& kernel, std::size_t items, std::size_t per_part)
{
    const std::size_t g = group_size(kernel);
    const std::size_t part = round_up(std::max<std::size_t>(per_part, 1), g);
    for (std::size_t first = 0; first < std::max<std::size_t>(items, 1); first += part) {
        stop_if_cancelled();
        const std::size_t count = std::min(part, round_up(std::max<std::size_t>(items, 1), g) - first);
        queue.enqueueNDRangeKernel(kernel, cl::NDRange(first), cl::NDRange(count), cl::NDRange(g));
        queue.finish();
    }
}

void ComputeContext::Impl::fill(cl::Buffer& buffer, const void* pattern, std::size_t size, std::size_t offset,
                                std::size_t bytes)
{
    if (bytes == 0)
        return;
    if (size == 1) {
        cl::Kernel k(program("device.cl"), "device_fill_bytes");
        set_args(k, buffer, cl_uint(offset), cl_uint(bytes), *static_cast<const cl_uchar*>(pattern));
        launch(k, bytes);
        return;
    }
    if ((size != 4 && size != 8) || offset % size || bytes % size)
        throw Error("internal error: a fill of " + std::to_string(bytes) + " bytes in " +
                    std::to_string(size) + "-byte units");
    cl_uint words[2];
    std::memcpy(words, pattern, size);
    if (size == 8 && words[0] != words[1])
        throw Error("internal error: an 8-byte fill pattern whose halves differ");
    if (offset / 4 + bytes / 4 > std::size_t(UINT32_MAX))
        throw Error("internal error: a fill past 2^32 words");
    cl::Kernel k(program("device.cl"), "device_fill_words");
    set_args(k, buffer, cl_uint(offset / 4), cl_uint(bytes / 4), words[0]);
    launch(k, bytes / 4);
}

std::uint64_t ComputeContext::Impl::loop_limit()
{
    if (loop_limit_)
        return loop_limit_;
    cl::Kernel probe(program("device.cl"), "device_loop_probe");
    cl::Buffer out(context, CL_MEM_WRITE_ONLY, sizeof(cl_uint));
    const cl_uint seed = 12345;
    const auto runs = [&](cl_uint n) {
        cl_uint x = seed;
        for (cl_uint k = 0; k < n; ++k)
            x = x * 1664525u + 1013904223u;
        set_args(probe, seed, n, out);
        queue.enqueueNDRangeKernel(probe, cl::NullRange, cl::NDRange(1), cl::NDRange(1));
        cl_uint got = 0;
        queue.enqueueReadBuffer(out, CL_TRUE, 0, sizeof got, &got);
        return got == x;
    };
    cl_uint good = 0, bad = cl_uint(1) << 21;
    if (runs(bad)) {
        loop_limit_ = UINT64_MAX;
    } else {
        while (bad - good > 1) {  // the largest n that runs to the end
            const cl_uint mid = good + (bad - good) / 2;
            (runs(mid) ? good : bad) = mid;
        }
        loop_limit_ = std::max<std::uint64_t>(good, 1);
    }
    loop_limit_ = std::min(loop_limit_, loop_cap);
    return loop_limit_;
}

std::mutex& compiler_mutex()
{
    static std::mutex m;
    return m;
}

cl::Program& ComputeContext::Impl::program(const std::vector<std::string>& files, const std::string& options)
{
    std::lock_guard<std::mutex> lock(programs_mutex);
    std::string key;
    for (const std::string& file : files)
        key += file + " ";
    key += options;
    auto it = programs.find(key);
    if (it != programs.end())
        return it->second;
    SetupTimer timer(SetupTimer::Kind::Programs);
    std::string source = kernel_source("common.h"), names;
    for (const std::string& file : files) {
        source += "\n#line 1 \"" + file + "\"\n" + kernel_source(file);
        names += (names.empty() ? "" : ", ") + file;
    }
    const std::string build_options = "-cl-std=CL1.2 " + options;
    const std::string cache_key = BinaryCache::key({"program", identity, source, build_options});
    if (const std::optional<std::string> binary = BinaryCache::load(cache_key)) {
        try {
            std::lock_guard<std::mutex> compiling(compiler_mutex());
            cl::Program prog(
                context, {device},
                cl::Program::Binaries{std::vector<unsigned char>(binary->begin(), binary->end())});
            prog.build({device}, build_options.c_str());
            return programs.emplace(key, prog).first->second;
        } catch (const cl::Error&) {
            // a binary this driver no longer takes: build from source, store anew
        }
    }
    std::unique_lock<std::mutex> compiling(compiler_mutex());
    cl::Program prog(context, source);
    try {
        prog.build({device}, build_options.c_str());
        compiling.unlock();
    } catch (const cl::Error&) {
        std::string log;
        try {
            log = prog.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device);
        } catch (const cl::Error&) {
        }
        throw KernelBuildError("OpenCL kernel " + names + " failed to build:\n" + log, log);
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

}  // namespace relief::host
