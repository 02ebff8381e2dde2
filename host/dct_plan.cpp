// SPDX-License-Identifier: Apache-2.0
#include "dct_plan.h"

namespace relief::host {

DctPlan::DctPlan(ComputeContext::Impl& c, std::size_t n0, std::size_t n1, const FftOf& fft_of, Axes axes)
    : c_(c), n0_(n0), n1_(n1), axes_(axes),
      work_(c.buffer(CL_MEM_READ_WRITE, sizeof(float) * FftPlan::row_stride(n0) * n1, "the DCT")),
      fft_(fft_of(work_))
{
    cl::Program& prog = c.program("dct.cl");
    const bool both = axes == Axes::Both;
    reorder_ = cl::Kernel(prog, both ? "dct_reorder" : "dct_axis1_reorder");
    unreorder_ = cl::Kernel(prog, both ? "dct_unreorder" : "dct_axis1_unreorder");
    post_ = cl::Kernel(prog, both ? "dct_forward_post" : "dct_axis1_forward_post");
    pre_ = cl::Kernel(prog, both ? "dct_inverse_pre" : "dct_axis1_inverse_pre");
    const cl_int stride = cl_int(FftPlan::row_stride(n0));
    for (cl::Kernel* k : {&reorder_, &unreorder_}) {
        k->setArg(1, cl_int(n0));
        k->setArg(2, cl_int(n1));
        k->setArg(3, stride);
    }
    reorder_.setArg(4, work_);
    unreorder_.setArg(0, work_);
    set_args(post_, work_, cl_int(n0), cl_int(n1));
    pre_.setArg(1, cl_int(n0));
    pre_.setArg(2, cl_int(n1));
    pre_.setArg(3, work_);
}

void DctPlan::forward(cl::Buffer& buffer)
{
    const std::size_t columns = n0_ / 2 + 1;
    reorder_.setArg(0, buffer);
    c_.launch(reorder_, FftPlan::row_stride(n0_) * n1_);
    fft_->forward(work_);
    post_.setArg(3, buffer);
    c_.launch(post_, (axes_ == Axes::Both ? n0_ : columns) * n1_);
}

void DctPlan::inverse(cl::Buffer& buffer)
{
    pre_.setArg(0, buffer);
    c_.launch(pre_, (n0_ / 2 + 1) * n1_);
    fft_->inverse(work_);
    unreorder_.setArg(4, buffer);
    c_.launch(unreorder_, n0_ * n1_);
}

}  // namespace relief::host
