// SPDX-License-Identifier: Apache-2.0
#pragma once
// 2-D (or 1-D) DCT-II and its inverse on the device, by one real FFT of the
// same size (FftPlan) and the reordering kernels of kernels/dct.cl; or the
// FFT along one axis with the DCT-II along the other, the same way. VkFFT
// 1.2.26's own DCT segfaulted at sizes such as 64x3001 and refuses shapes
// that need more than one pass on GPUs (error 3004); FftPlan avoids both.
// Included only by host/*.cpp.
#include <CL/opencl.hpp>

#include <cstddef>
#include <functional>
#include <memory>

#include "fft/fft_plan.h"
#include "device/opencl_context.h"

namespace relief::host {

class DctPlan {
public:
    // The FFT plan of n0 x n1 built against `work` (a plan cache's: the
    // DCT's transforms are that FFT's).
    using FftOf = std::function<std::shared_ptr<FftPlan>(cl::Buffer& work)>;
    // Both: the 2-D (n1 == 1: 1-D) DCT-II. Axis1: the real FFT along axis 0
    // and the DCT-II along axis 1, for a map periodic along axis 0 and free
    // along axis 1 (kernels/dct.cl's dct_axis1_*).
    enum class Axes { Both, Axis1 };
    // A plan over n0 (fast axis) x n1. n0 >= 2.
    DctPlan(ComputeContext::Impl& c, std::size_t n0, std::size_t n1, const FftOf& fft_of,
            Axes axes = Axes::Both);

    // In place; inverse(forward(x)) == x. Both: on a dense n0 x n1 float
    // buffer, the unnormalised X[k0,k1] = sum x cos(pi k0 (2i+1)/2n0)
    // cos(pi k1 (2j+1)/2n1). Axis1: on an R2C grid (rows of
    // FftPlan::row_stride(n0) floats), the unnormalised
    // X[k0,k1] = sum x e^{-2 pi i k0 i/n0} cos(pi k1 (2j+1)/2n1) for
    // k0 <= n0/2, n0/2 + 1 complex values a row.
    void forward(cl::Buffer& buffer);
    void inverse(cl::Buffer& buffer);

private:
    ComputeContext::Impl& c_;
    std::size_t n0_, n1_;
    Axes axes_;
    cl::Buffer work_;               // the R2C grid
    std::shared_ptr<FftPlan> fft_;  // from fft_of: the context's plan of this size
    cl::Kernel reorder_, unreorder_, post_, pre_;
    // The twiddles (cos, sin)(pi k / 2n) of each axis, k < n, from double:
    // the kernels combine them by the angle-sum rules instead of calling
    // cospi()/sinpi() per value (four calls a value took 13% of a batch of
    // 512^2 heights on PoCL).
    cl::Buffer twiddles0_, twiddles1_;
};

}  // namespace relief::host
