// SPDX-License-Identifier: Apache-2.0
#pragma once
// Real-to-complex FFT plans on the device, by VkFFT's OpenCL backend
// (Debian's libvkfft-dev). Used by the Poisson and ray stages, and by
// DctPlan. Included only by host/*.cpp.
//
// VkFFT 1.2.26's strided-axis Bluestein kernels (a strided length with a
// prime factor > 13) segfaulted on PoCL at sizes such as 64x3001, and its
// DCT at more. So a 2-D transform is VkFFT's own only when the strided
// length factors into 2..13; otherwise it is a batched 1-D R2C along the
// contiguous axis, a transpose of the half spectrum (kernels/fft.cl), a
// batched 1-D C2C along the former columns and a transpose back.
// Its Bluestein kernels also segfault on PoCL once the length passes about
// 21000 points (21011 ran, 21839, 25013, 32660, 65320 and 65519 crashed,
// along either axis), so such lengths are refused (kMaxBluesteinLength).
#include <string>
#include <CL/opencl.hpp>

#include <cstddef>
#include <functional>
#include <memory>

#include "device/opencl_context.h"

namespace relief::host {

class FftPlan {
public:
    // Floats per row of the buffer a plan works on: R2C pads each row to
    // 2 * (n0/2 + 1) floats.
    static std::size_t row_stride(std::size_t n0) { return 2 * (n0 / 2 + 1); }
    // Longest axis with a prime factor above 13 that is planned.
    static constexpr std::size_t kMaxBluesteinLength = 20000;
    // "" when an n0 x n1 plan can be made, else why not, for users.
    static std::string unsupported(std::size_t n0, std::size_t n1);

    // A 2-D plan over n0 (fast axis) x n1; a 1-D plan when n1 == 1. n0 >= 2.
    // Launches may name any buffer of row_stride * n1 floats; VkFFT builds
    // its kernels against `buffer`, which the plan keeps alive.
    FftPlan(ComputeContext::Impl& c, std::size_t n0, std::size_t n1, cl::Buffer& buffer);
    ~FftPlan();
    FftPlan(const FftPlan&) = delete;
    FftPlan& operator=(const FftPlan&) = delete;

    // Enqueues the in-place transform of `buffer` on the context's queue;
    // the inverse is normalised (inverse(forward(x)) == x).
    void forward(cl::Buffer& buffer);
    void inverse(cl::Buffer& buffer);

    // Whether the plan is VkFFT's own 2-D transform (rows and the strided
    // axis in one), not rows, a transpose and rows again: so only when the
    // strided axis's length has no prime factor above 13 (Bluestein along
    // a strided axis crashed PoCL).
    bool whole() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// The real w x h result of an inverse transform, read out of `grid` (rows
// `stride` floats apart) into the memory `sink` gives. A `transposed` grid
// (h x w: a one-texel-wide map, a 1-D transform along y in one row; or a
// map whose periodic axis is y) is gathered through `spare` (at least w * h
// floats); otherwise `spare` is freed before `sink` is called. The caller
// holds c.mutex.
float* read_real_result(ComputeContext::Impl& c, cl::Buffer& grid, cl::Buffer& spare, std::size_t stride,
                        int w, int h, bool transposed, const std::function<float*()>& sink);

// How many of VkFFT's programs this process has made from binaries in the
// binary cache, rather than from source (a plan of a size met before, in
// this process or an earlier one, should make them all so).
std::size_t vkfft_programs_from_cache();

}  // namespace relief::host
