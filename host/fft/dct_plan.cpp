// SPDX-License-Identifier: Apache-2.0
#include "fft/dct_plan.h"

#include <cmath>
#include <vector>

namespace relief::host {

namespace {

// (cos, sin)(pi k / 2n) for k < n, as float2.
cl::Buffer twiddles(ComputeContext::Impl& c, std::size_t n)
{
    std::vector<cl_float2> w(n);
    for (std::size_t k = 0; k < n; ++k) {
        const double a = M_PI * double(k) / (2.0 * double(n));
        w[k] = {{float(std::cos(a)), float(std::sin(a))}};
    }
    return c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(cl_float2) * n, "the DCT", w.data());
}

}  // namespace

DctPlan::DctPlan(ComputeContext::Impl& c, std::size_t n0, std::size_t n1, const FftOf& fft_of, Axes axes)
    : c_(c), n0_(n0), n1_(n1), axes_(axes),
      work_(c.buffer(CL_MEM_READ_WRITE, sizeof(float) * FftPlan::row_stride(n0) * n1, "the DCT")),
      fft_(fft_of(work_)), twiddles0_(twiddles(c, n0)), twiddles1_(twiddles(c, n1))
{
    cl::Program& prog = c.program("dct.cl");
    const bool both = axes == Axes::Both;
    reorder_ = cl::Kernel(prog, both ? "dct_reorder" : "dct_axis1_reorder");
    unreorder_ = cl::Kernel(prog, both ? "dct_unreorder" : "dct_axis1_unreorder");
    post_ = cl::Kernel(prog, both ? "dct_forward_post" : "dct_axis1_forward_post");
    pre_ = cl::Kernel(prog, both ? "dct_inverse_pre" : "dct_axis1_inverse_pre");
    const cl_int stride = cl_int(FftPlan::row_stride(n0));
    // The buffer transformed is set per call: reorder_'s argument 0,
    // unreorder_'s 4, post_'s 3 and pre_'s 0.
    set_args_at(reorder_, 1, cl_int(n0), cl_int(n1), stride, work_);
    set_args(unreorder_, work_, cl_int(n0), cl_int(n1), stride);
    set_args(post_, work_, cl_int(n0), cl_int(n1));
    set_args_at(post_, 4, twiddles0_, twiddles1_);
    set_args_at(pre_, 1, cl_int(n0), cl_int(n1), work_, twiddles0_, twiddles1_);
}

void DctPlan::forward(cl::Buffer& buffer)
{
    const std::size_t columns = n0_ / 2 + 1;
    set_args_at(reorder_, 0, buffer);
    c_.launch(reorder_, FftPlan::row_stride(n0_) * n1_);
    fft_->forward(work_);
    set_args_at(post_, 3, buffer);
    c_.launch(post_, (axes_ == Axes::Both ? n0_ : columns) * n1_);
}

void DctPlan::inverse(cl::Buffer& buffer)
{
    set_args_at(pre_, 0, buffer);
    c_.launch(pre_, (n0_ / 2 + 1) * n1_);
    fft_->inverse(work_);
    set_args_at(unreorder_, 4, buffer);
    c_.launch(unreorder_, n0_ * n1_);
}

}  // namespace relief::host
