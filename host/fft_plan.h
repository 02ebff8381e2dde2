#pragma once
// Real-to-complex FFT plans on the device, by VkFFT's OpenCL backend
// (Debian's libvkfft-dev). Used by the Poisson and ray stages, and by
// DctPlan. Included only by host/*.cpp.
//
// VkFFT 1.2.26 is asked for batched 1-D transforms along the contiguous
// axis only; a 2-D transform transposes the half spectrum between the two
// passes (kernels/fft.cl). Its strided-axis kernels segfaulted on PoCL at
// sizes such as 64x3001 (Bluestein along the strided axis), and its DCT at
// more; the contiguous 1-D transforms are its most common path.
#include <CL/opencl.hpp>

#include <cstddef>
#include <memory>

#include "opencl_context.h"

namespace relief::host {

class FftPlan {
public:
    // Floats per row of the buffer a plan works on: R2C pads each row to
    // 2 * (n0/2 + 1) floats.
    static std::size_t row_stride(std::size_t n0) { return 2 * (n0 / 2 + 1); }

    // A 2-D plan over n0 (fast axis) x n1; a 1-D plan when n1 == 1. n0 >= 2.
    // Launches may name any buffer of row_stride * n1 floats.
    FftPlan(ComputeContext::Impl& c, std::size_t n0, std::size_t n1);
    ~FftPlan();
    FftPlan(const FftPlan&) = delete;
    FftPlan& operator=(const FftPlan&) = delete;

    // Enqueues the in-place transform of `buffer` on the context's queue;
    // the inverse is normalised (inverse(forward(x)) == x).
    void forward(cl::Buffer& buffer);
    void inverse(cl::Buffer& buffer);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace relief::host
