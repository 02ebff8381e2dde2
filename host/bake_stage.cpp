#include "bake_stage.h"

#include "errors.h"
#include "opencl_context.h"

namespace relief::host {

void bake_gather(ComputeContext& ctx, const float* src, int w, int h, int nch,
                 const float* offsets, bool periodic, BakeFilter filter, float* dst)
{
    if (w < 1 || h < 1 || nch < 1)
        throw Error("baking needs a non-empty texture");
    check_index_range(w, h, "bake");
    const std::size_t n = std::size_t(w) * h;
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        cl::Program& prog = c.program("bake.cl");
        cl::Buffer in = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * n * nch, "baking", src);
        cl::Buffer off = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(cl_float2) * n, "baking", offsets);
        cl::Buffer out = c.buffer(CL_MEM_WRITE_ONLY, sizeof(float) * n * nch, "baking");
        cl::Kernel k(prog, "bake_gather");
        int a = 0;
        k.setArg(a++, in);
        k.setArg(a++, cl_int(w));
        k.setArg(a++, cl_int(h));
        k.setArg(a++, cl_int(nch));
        k.setArg(a++, off);
        k.setArg(a++, cl_int(periodic));
        k.setArg(a++, cl_int(filter == BakeFilter::Bicubic));
        k.setArg(a++, out);
        c.queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(padded(n)), cl::NDRange(kGroupSize));
        c.queue.enqueueReadBuffer(out, CL_TRUE, 0, sizeof(float) * n * nch, dst);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the bake stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }
}

} // namespace relief::host
