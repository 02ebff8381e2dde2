// VkFFT is a single large header that generates and builds its kernels at
// plan time; it is confined to this file.
#include "fft_plan.h"

#define VKFFT_BACKEND 3
#include <vkFFT.h>

#include <string>

#include "errors.h"

namespace relief::host {

struct FftPlan::Impl {
    VkFFTApplication app = {};
    cl_device_id device = nullptr;
    cl_context context = nullptr;
    cl_platform_id platform = nullptr;
    cl_mem buffer = nullptr;
    uint64_t size = 0;
    bool initialised = false;
};

FftPlan::FftPlan(cl::Context& context, cl::Device& device, Kind kind, std::size_t n0,
                 std::size_t n1, cl::Buffer& buffer)
    : impl_(new Impl)
{
    if (n0 < 2 || n1 < 1)
        throw Error("internal error: FFT plan of size " + std::to_string(n0) + "x" +
                    std::to_string(n1));
    impl_->device = device();
    impl_->context = context();
    impl_->platform = device.getInfo<CL_DEVICE_PLATFORM>();
    impl_->size = sizeof(float) * row_stride(kind, n0) * n1;
    impl_->buffer = buffer();

    VkFFTConfiguration config = {};
    config.FFTdim = n1 > 1 ? 2 : 1;
    config.size[0] = n0;
    config.size[1] = n1;
    if (kind == Kind::RealToComplex)
        config.performR2C = 1;
    else
        config.performDCT = 2;
    config.normalize = 1;
    config.device = &impl_->device;
    config.context = &impl_->context;
    config.platform = &impl_->platform;
    config.buffer = &impl_->buffer;
    config.bufferSize = &impl_->size;
    VkFFTResult r = initializeVkFFT(&impl_->app, config);
    if (r != VKFFT_SUCCESS)
        throw Error("VkFFT could not plan a " + std::to_string(n0) + "x" + std::to_string(n1) +
                    " transform (VkFFT error " + std::to_string(int(r)) + ")");
    impl_->initialised = true;
}

FftPlan::~FftPlan()
{
    if (impl_->initialised)
        deleteVkFFT(&impl_->app);
}

void FftPlan::run(cl::CommandQueue& queue, cl::Buffer& buffer, int direction)
{
    cl_command_queue q = queue();
    cl_mem b = buffer();
    VkFFTLaunchParams launch = {};
    launch.commandQueue = &q;
    launch.buffer = &b;
    VkFFTResult r = VkFFTAppend(&impl_->app, direction, &launch);
    if (r != VKFFT_SUCCESS)
        throw Error("VkFFT transform failed (VkFFT error " + std::to_string(int(r)) + ")");
}

void FftPlan::forward(cl::CommandQueue& queue, cl::Buffer& buffer)
{
    run(queue, buffer, -1);
}

void FftPlan::inverse(cl::CommandQueue& queue, cl::Buffer& buffer)
{
    run(queue, buffer, 1);
}

} // namespace relief::host
