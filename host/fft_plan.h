#pragma once
// Real-to-complex FFT and DCT-II plans on the device, by VkFFT's OpenCL
// backend (Debian's libvkfft-dev). Used by the Poisson stage; included only
// by host/*.cpp.
#include <CL/opencl.hpp>

#include <cstddef>
#include <memory>

namespace relief::host {

class FftPlan {
public:
    enum class Kind {
        RealToComplex,  // forward R2C / inverse C2R, in place, rows padded
        Dct2,           // forward DCT-II / inverse DCT-III, in place
    };

    // Floats per row of the buffer a plan works on: R2C pads each row to
    // 2 * (n0/2 + 1) floats.
    static std::size_t row_stride(Kind kind, std::size_t n0)
    {
        return kind == Kind::RealToComplex ? 2 * (n0 / 2 + 1) : n0;
    }

    // A 2-D plan over n0 (fast axis) x n1; a 1-D plan when n1 == 1. n0 >= 2.
    // `buffer` (row_stride * n1 floats) is the one the plan is built for;
    // launches may name any buffer of that size.
    FftPlan(cl::Context& context, cl::Device& device, Kind kind, std::size_t n0, std::size_t n1,
            cl::Buffer& buffer);
    ~FftPlan();
    FftPlan(const FftPlan&) = delete;
    FftPlan& operator=(const FftPlan&) = delete;

    // Enqueues the transform of `buffer` on `queue`; the inverse is
    // normalised (inverse(forward(x)) == x).
    void forward(cl::CommandQueue& queue, cl::Buffer& buffer);
    void inverse(cl::CommandQueue& queue, cl::Buffer& buffer);

private:
    void run(cl::CommandQueue& queue, cl::Buffer& buffer, int direction);
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace relief::host
