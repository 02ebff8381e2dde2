// SPDX-License-Identifier: Apache-2.0
// VkFFT is a single large header that generates and builds its kernels at
// plan time; it is confined to this file.
#include "fft/fft_plan.h"

#include <array>
#include <atomic>
#include <clocale>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "device/binary_cache.h"
#include "device/cancel.h"
#include "errors.h"
#include "device/setup_times.h"
#include "fft/vkfft_version.h"
#include "device/queue_wait.h"

// VkFFT builds its kernels from source at every plan, and on PoCL every
// clBuildProgram from source runs Clang's preprocessor (about 0.02 s each,
// four per 2-D plan) even when PoCL's own cache holds the result; VkFFT's
// own saveApplicationToString cannot help (1.2.26 writes the binaries with
// sprintf("%s"), and PoCL's hold NUL bytes). So, in this file only, VkFFT's
// program creation and build go through these two functions, which keep the
// binaries in relief's BinaryCache like relief's own programs: a plan of a
// size met before builds from binaries.
namespace {

// Per thread: initializeVkFFT creates and builds its programs on the
// thread that plans, and two threads may plan at once (relief::prepare).
struct VkfftBuilds {
    const std::string* identity = nullptr;                       // the device's; null: no caching
    const relief::host::ComputeContext::Impl* limits = nullptr;  // the launch limits relief uses
    bool load = true;                                            // false: build from source, store anew
    std::map<cl_program, std::string> from_source;               // -> the key to store its binary under
    std::vector<std::string> from_cache;                         // keys the plan being made loaded
};
thread_local VkfftBuilds vkfft_builds;
std::atomic<std::size_t> programs_from_cache{0};

// VkFFT 1.2.26 transforms in place: a work-group reads its elements from
// global memory into local memory, and after barriers that fence local
// memory only, its work-items write results to addresses other items of the
// group read. Under the OpenCL memory model a local fence does not order
// those global accesses, so the read and the write race (Oclgrind's
// --data-races reports every element). Every barrier VkFFT emits fences
// global memory too, which makes the write happen after every read.
std::string fence_global_memory_too(std::string source)
{
    static const std::string local_only = "barrier(CLK_LOCAL_MEM_FENCE)";
    static const std::string both = "barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE)";
    for (std::size_t at = source.find(local_only); at != std::string::npos;
         at = source.find(local_only, at + both.size()))
        source.replace(at, local_only.size(), both);
    return source;
}

cl_program relief_vkfft_create_program(cl_context context, cl_uint count, const char** strings,
                                       const size_t* lengths, cl_int* err)
{
    std::string source;
    for (cl_uint i = 0; i < count; ++i)
        source.append(strings[i], lengths && lengths[i] ? lengths[i] : std::strlen(strings[i]));
    source = fence_global_memory_too(std::move(source));
    std::lock_guard<std::mutex> compiling(relief::host::compiler_mutex());
    std::string key;
    if (vkfft_builds.identity) {
        key = relief::host::BinaryCache::key({"vkfft", *vkfft_builds.identity, source});
        cl_device_id device = nullptr;
        if (const std::optional<std::string> binary =
                vkfft_builds.load ? relief::host::BinaryCache::load(key) : std::nullopt;
            binary &&
            clGetContextInfo(context, CL_CONTEXT_DEVICES, sizeof device, &device, nullptr) == CL_SUCCESS) {
            const size_t size = binary->size();
            const auto* bytes = reinterpret_cast<const unsigned char*>(binary->data());
            cl_int status = CL_SUCCESS;
            cl_program program =
                clCreateProgramWithBinary(context, 1, &device, &size, &bytes, nullptr, &status);
            if (status == CL_SUCCESS) {
                vkfft_builds.from_cache.push_back(key);
                ++programs_from_cache;
                if (err)
                    *err = status;
                return program;
            }
        }
    }
    const char* text = source.c_str();
    const size_t length = source.size();
    cl_program program = clCreateProgramWithSource(context, 1, &text, &length, err);
    if (program && !key.empty())
        vkfft_builds.from_source[program] = key;
    return program;
}

cl_int relief_vkfft_build_program(cl_program program, cl_uint devices, const cl_device_id* device_list,
                                  const char* options, void(CL_CALLBACK* notify)(cl_program, void*),
                                  void* data)
{
    cl_int status;
    {
        std::lock_guard<std::mutex> compiling(relief::host::compiler_mutex());
        status = clBuildProgram(program, devices, device_list, options, notify, data);
    }
    std::string key;
    if (auto it = vkfft_builds.from_source.find(program); it != vkfft_builds.from_source.end()) {
        key = it->second;
        vkfft_builds.from_source.erase(it);
    }
    size_t size = 0;
    if (status == CL_SUCCESS && !key.empty() &&
        clGetProgramInfo(program, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, nullptr) == CL_SUCCESS &&
        size > 0) {
        std::string binary(size, '\0');
        unsigned char* bytes = reinterpret_cast<unsigned char*>(binary.data());
        if (clGetProgramInfo(program, CL_PROGRAM_BINARIES, sizeof bytes, &bytes, nullptr) == CL_SUCCESS)
            relief::host::BinaryCache::store(key, binary);
    }
    return status;
}

// VkFFT sizes its work-groups and local memory from the device's queries;
// here it gets the limits relief's own kernels keep to (the device's, or
// lower with RELIEF_MAX_WORK_GROUP_SIZE and RELIEF_LOCAL_MEM_SIZE), so a
// test of a smaller device covers the transforms too.
cl_int relief_vkfft_device_info(cl_device_id device, cl_device_info param, size_t size, void* value,
                                size_t* returned)
{
    const cl_int status = clGetDeviceInfo(device, param, size, value, returned);
    const relief::host::ComputeContext::Impl* limits = vkfft_builds.limits;
    if (status != CL_SUCCESS || !value || !limits)
        return status;
    if (param == CL_DEVICE_MAX_WORK_GROUP_SIZE && size >= sizeof(size_t)) {
        *static_cast<size_t*>(value) = std::min(*static_cast<size_t*>(value), limits->max_group);
    } else if (param == CL_DEVICE_MAX_WORK_ITEM_SIZES) {
        for (size_t i = 0; i < size / sizeof(size_t) && i < 3; ++i)
            static_cast<size_t*>(value)[i] = std::min(static_cast<size_t*>(value)[i], limits->max_group);
    } else if (param == CL_DEVICE_LOCAL_MEM_SIZE && size >= sizeof(cl_ulong)) {
        *static_cast<cl_ulong*>(value) =
            std::min<cl_ulong>(*static_cast<cl_ulong*>(value), limits->local_memory);
    }
    return status;
}

}  // namespace

#define VKFFT_BACKEND 3
#define clCreateProgramWithSource relief_vkfft_create_program
#define clBuildProgram relief_vkfft_build_program
#define clGetDeviceInfo relief_vkfft_device_info
#include <vkFFT.h>
#undef clCreateProgramWithSource
#undef clBuildProgram
#undef clGetDeviceInfo

namespace relief::host {

namespace {

// Whether VkFFT decomposes n into radix kernels (primes <= 13) rather than
// Bluestein's algorithm.
bool smooth(std::size_t n)
{
    for (std::size_t p : {2, 3, 5, 7, 11, 13})
        while (n % p == 0)
            n /= p;
    return n == 1;
}

// VkFFT 1.2.26 plans no R2C transform of an odd length that does not fit
// the device's local memory in one pass (Bluestein's algorithm, or long
// odd lengths): with 32 KiB (llvmpipe, many GPUs) any odd length above
// 2048 with a prime factor above 13 is refused (2049, 3001, 4099, 8191).
struct R2cUnsupported : Error {
    using Error::Error;
};

// One VkFFT application: a batched 1-D transform along the contiguous axis,
// or (rows > 1) the whole 2-D R2C transform.
class Transform1d {
public:
    Transform1d(ComputeContext::Impl& c, std::size_t n, std::size_t batches, bool real, cl::Buffer& buffer,
                std::size_t bytes, std::size_t rows = 1)
        : limits_(c), device_(c.device()), context_(c.context()), buffer_(buffer()), size_(bytes)
    {
        platform_ = c.device.getInfo<CL_DEVICE_PLATFORM>();
        VkFFTConfiguration config = {};
        config.FFTdim = rows > 1 ? 2 : 1;
        config.size[0] = n;
        config.size[1] = rows;
        config.numberBatches = batches;
        config.performR2C = real ? 1 : 0;
        config.normalize = 1;
        config.device = &device_;
        config.context = &context_;
        config.platform = &platform_;
        config.buffer = &buffer_;
        config.bufferSize = &size_;
        VkFFTResult r = plan(config, c.identity, true);
        if (r != VKFFT_SUCCESS && !loaded_.empty())
            r = plan(config, c.identity, false);  // a cached binary VkFFT could not use: replace them all
        if (r == VKFFT_ERROR_UNSUPPORTED_FFT_LENGTH_R2C)
            throw R2cUnsupported("VkFFT plans no real-to-complex transform of size " + std::to_string(n) +
                                 " on this device");
        if (r != VKFFT_SUCCESS)
            throw Error("VkFFT could not plan a transform of size " + std::to_string(n) + " (VkFFT error " +
                        std::to_string(int(r)) + ")");
    }
    ~Transform1d() { deleteVkFFT(&app_); }

    // initializeVkFFT with its programs into the binary cache, and from it
    // when `load`.
    VkFFTResult plan(const VkFFTConfiguration& config, const std::string& identity, bool load)
    {
        vkfft_builds.identity = &identity;
        vkfft_builds.limits = &limits_;
        vkfft_builds.load = load;
        vkfft_builds.from_cache.clear();
        vkfft_builds.from_source.clear();
        app_ = {};
        // VkFFT keeps setlocale(LC_ALL, NULL)'s pointer while it sets "C",
        // then restores the locale from it: freed memory unless the locale
        // already is "C" (whose name is static). So it is made "C" here and
        // restored from a copy (Python, for one, sets a locale at start).
        const char* current = std::setlocale(LC_ALL, nullptr);
        const std::string locale = current ? current : "C";
        std::setlocale(LC_ALL, "C");
        const VkFFTResult r = initializeVkFFT(&app_, config);
        std::setlocale(LC_ALL, locale.c_str());
        vkfft_builds.identity = nullptr;
        vkfft_builds.limits = nullptr;
        loaded_ = vkfft_builds.from_cache;
        return r;
    }
    Transform1d(const Transform1d&) = delete;
    Transform1d& operator=(const Transform1d&) = delete;

    void run(cl::CommandQueue& queue, cl::Buffer& buffer, int direction)
    {
        // VkFFT keeps the pointers it is given, to the cl_mem and the queue,
        // and reads through them at later launches too (each kernel
        // argument is set from what the pointer holds then; a pointer it
        // thinks unchanged is not updated). So both point at members that
        // outlive the plan, set to this launch's buffer and queue: a pointer
        // to a local of this function would be read after it is gone (under
        // Oclgrind the transforms read a stale buffer).
        queue_ = queue();
        buffer_ = buffer();
        VkFFTLaunchParams launch = {};
        launch.commandQueue = &queue_;
        launch.buffer = &buffer_;
        stop_if_cancelled();
        VkFFTResult r = VkFFTAppend(&app_, direction, &launch);
        if (r != VKFFT_SUCCESS)
            throw Error("VkFFT transform failed (VkFFT error " + std::to_string(int(r)) + ")");
    }

private:
    VkFFTApplication app_ = {};
    const ComputeContext::Impl& limits_;  // the launch limits VkFFT is shown
    std::vector<std::string> loaded_;     // cache keys this plan's programs came from
    cl_device_id device_;
    cl_context context_;
    cl_platform_id platform_ = nullptr;
    cl_mem buffer_;  // the plan's buffer, then each launch's (see run)
    cl_command_queue queue_ = nullptr;
    uint64_t size_;
};

}  // namespace

struct FftPlan::Impl {
    ComputeContext::Impl& c;
    std::size_t n0, n1, columns;
    std::unique_ptr<Transform1d> rows;  // R2C along axis 0, n1 batches (or 2-D)
    bool whole = false;                 // `rows` is the 2-D transform
    // Where VkFFT plans no R2C of length n0 (R2cUnsupported), `rows` is a
    // C2C transform of the rows widened to complex in `wide` (n0 x n1
    // complex): kernels/fft.cl widens, keeps the half spectrum, rebuilds the
    // Hermitian whole for the inverse and takes its real part.
    bool complex_rows = false;
    cl::Buffer wide;
    cl::Kernel widen, narrow, hermitian, real_part;
    cl::Buffer work;                           // the transposed half spectrum
    std::unique_ptr<Transform1d> columns_fft;  // C2C along axis 1, `columns` batches
    cl::Kernel transpose;
    cl::Buffer built_against;  // VkFFT's kernels were built against it: kept alive with the plan

    explicit Impl(ComputeContext::Impl& ctx) : c(ctx) {}

    void transpose_to(cl::Buffer& in, int rows_in, int columns_in, cl::Buffer& out)
    {
        set_args(transpose, in, cl_int(rows_in), cl_int(columns_in), out);
        c.launch(transpose, std::size_t(rows_in) * columns_in);
    }
};

std::string FftPlan::unsupported(std::size_t n0, std::size_t n1)
{
    for (std::size_t n : {n0, n1}) {
        if (n <= kMaxBluesteinLength || smooth(n))
            continue;
        std::size_t up = n;  // the next length made of the primes 2..13
        while (!smooth(up))
            ++up;
        std::size_t down = n;
        while (!smooth(down))
            --down;
        return "an FFT along an axis of " + std::to_string(n) +
               " texels, which has a prime factor above 13, is supported only up to " +
               std::to_string(kMaxBluesteinLength) + " texels; crop the map to " + std::to_string(down) +
               " or pad it to " + std::to_string(up) + " texels (lengths made of the primes 2 to 13)";
    }
    return "";
}

FftPlan::FftPlan(ComputeContext::Impl& c, std::size_t n0, std::size_t n1, cl::Buffer& buffer)
    : impl_(new Impl(c))
{
    if (const std::string why = unsupported(n0, n1); !why.empty())
        throw Error(why);
    SetupTimer timer(SetupTimer::Kind::Plans);
    if (n0 < 2 || n1 < 1)
        throw Error("internal error: FFT plan of size " + std::to_string(n0) + "x" + std::to_string(n1));
    auto& p = *impl_;
    p.n0 = n0;
    p.n1 = n1;
    p.columns = n0 / 2 + 1;
    p.built_against = buffer;
    const std::size_t bytes = sizeof(float) * row_stride(n0) * n1;
    // VkFFT builds its kernels against a buffer; launches name their own.
    // A strided axis of radix sizes is VkFFT's common 2-D path, and faster
    // (no transposes); only Bluestein along the strided axis crashed.
    p.whole = n1 > 1 && smooth(n1);
    try {
        if (p.whole) {
            p.rows.reset(new Transform1d(c, n0, 1, true, buffer, bytes, n1));
            return;
        }
        p.rows.reset(new Transform1d(c, n0, n1, true, buffer, bytes));
    } catch (const R2cUnsupported&) {
        p.whole = false;
        p.complex_rows = true;
        const std::size_t wide_bytes = sizeof(cl_float2) * n0 * n1;
        p.wide = c.buffer(CL_MEM_READ_WRITE, wide_bytes, "the FFT");
        p.rows.reset(new Transform1d(c, n0, n1, false, p.wide, wide_bytes));
        cl::Program& prog = c.program("fft.cl");
        p.widen = cl::Kernel(prog, "fft_widen");
        p.narrow = cl::Kernel(prog, "fft_narrow");
        p.hermitian = cl::Kernel(prog, "fft_hermitian");
        p.real_part = cl::Kernel(prog, "fft_real_part");
    }
    if (n1 > 1) {
        p.work = c.buffer(CL_MEM_READ_WRITE, bytes, "the FFT");
        p.columns_fft.reset(new Transform1d(c, n1, p.columns, false, p.work, bytes));
        p.transpose = cl::Kernel(c.program("fft.cl"), "fft_transpose");
    }
}

FftPlan::~FftPlan() = default;

bool FftPlan::whole() const
{
    return impl_->whole;
}

void FftPlan::forward(cl::Buffer& buffer)
{
    auto& p = *impl_;
    if (p.complex_rows) {
        const cl_int n0 = cl_int(p.n0), n1 = cl_int(p.n1);
        set_args(p.widen, buffer, n0, n1, cl_int(row_stride(p.n0)), p.wide);
        p.c.launch(p.widen, p.n0 * p.n1);
        p.rows->run(p.c.queue, p.wide, -1);
        set_args(p.narrow, p.wide, n0, n1, buffer);
        p.c.launch(p.narrow, p.columns * p.n1);
    } else {
        p.rows->run(p.c.queue, buffer, -1);
    }
    if (p.n1 == 1 || p.whole)
        return;
    p.transpose_to(buffer, int(p.n1), int(p.columns), p.work);
    p.columns_fft->run(p.c.queue, p.work, -1);
    p.transpose_to(p.work, int(p.columns), int(p.n1), buffer);
}

void FftPlan::inverse(cl::Buffer& buffer)
{
    auto& p = *impl_;
    if (p.n1 > 1 && !p.whole) {
        p.transpose_to(buffer, int(p.n1), int(p.columns), p.work);
        p.columns_fft->run(p.c.queue, p.work, 1);
        p.transpose_to(p.work, int(p.columns), int(p.n1), buffer);
    }
    if (p.complex_rows) {
        const cl_int n0 = cl_int(p.n0), n1 = cl_int(p.n1);
        set_args(p.hermitian, buffer, n0, n1, p.wide);
        p.c.launch(p.hermitian, p.n0 * p.n1);
        p.rows->run(p.c.queue, p.wide, 1);
        set_args(p.real_part, p.wide, n0, n1, cl_int(row_stride(p.n0)), buffer);
        p.c.launch(p.real_part, row_stride(p.n0) * p.n1);
    } else {
        p.rows->run(p.c.queue, buffer, 1);
    }
}

float* read_real_result(ComputeContext::Impl& c, cl::Buffer& grid, cl::Buffer& spare, std::size_t stride,
                        int w, int h, bool transposed, const std::function<float*()>& sink)
{
    const std::size_t n = std::size_t(w) * std::size_t(h);
    if (transposed) {  // gathered out of the grid's rows, which are columns
        cl::Kernel gather(c.program("poisson.cl"), "poisson_gather");
        // (n0 = h: the grid's axis 0 is y)
        set_args(gather, grid, cl_int(stride), cl_int(h), cl_int(w), cl_int(w), cl_int(1), spare);
        c.launch(gather, n);
        float* out = sink();
        read_asking(c.queue, spare, 0, sizeof(float) * n, out);
        return out;
    }
    // Rows out of the padded grid straight into the result.
    spare = cl::Buffer();
    float* out = sink();
    const std::array<std::size_t, 3> origin{0, 0, 0};
    const std::array<std::size_t, 3> region{sizeof(float) * std::size_t(w), std::size_t(h), 1};
    cl::Event done;
    c.queue.enqueueReadBufferRect(grid, CL_FALSE, origin, origin, region, sizeof(float) * stride, 0,
                                  sizeof(float) * std::size_t(w), 0, out, nullptr, &done);
    complete_asking(c.queue, done);
    return out;
}

std::string vkfft_version()
{
    const int v = VkFFTGetVersion();  // X.XX.XX
    return std::to_string(v / 10000) + "." + std::to_string(v / 100 % 100) + "." + std::to_string(v % 100);
}

std::size_t vkfft_programs_from_cache()
{
    return programs_from_cache.load();
}

}  // namespace relief::host
