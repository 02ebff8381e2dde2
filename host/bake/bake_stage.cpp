// SPDX-License-Identifier: Apache-2.0
#include "bake/bake_stage.h"

#include <vector>

#include "errors.h"
#include "device/opencl_context.h"
#include "device/queue_wait.h"

namespace relief::host {

void bake_gather(ComputeContext& ctx, const float* src, int w, int h, int nch, const float* offsets,
                 Periodic periodic, BakeFilter filter, float* dst)
{
    if (w < 1 || h < 1 || nch < 1)
        throw Error("baking needs a non-empty texture");
    check_index_range(w, h, "bake");
    const std::size_t n = std::size_t(w) * h;
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        cl::Program& prog = c.program("bake.cl");
        cl::Buffer off =
            c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(cl_float2) * n, "baking", offsets);
        // All channels in one pass when they fit one device buffer; else one
        // channel plane at a time (the same arithmetic, the same bits): a
        // 16384^2 RGBA float texture passes many devices' limit.
        const bool planar = sizeof(float) * n * nch > c.buffer_limit();
        const int pass_channels = planar ? 1 : nch;
        const std::size_t values = n * pass_channels;
        cl::Buffer in = c.buffer(CL_MEM_READ_ONLY, sizeof(float) * values, "baking");
        cl::Buffer out = c.buffer(CL_MEM_WRITE_ONLY, sizeof(float) * values, "baking");
        cl::Kernel k(prog, "bake_gather");
        set_args(k, in, cl_int(w), cl_int(h), cl_int(pass_channels), off, cl_int(periodic.bits()),
                 cl_int(filter == BakeFilter::Bicubic), out);
        std::vector<float> plane(planar ? n : 0);
        for (int ch = 0; ch < (planar ? nch : 1); ++ch) {
            if (planar)
                for (std::size_t i = 0; i < n; ++i)
                    plane[i] = src[i * nch + ch];
            write_asking(c.queue, in, 0, sizeof(float) * values, planar ? plane.data() : src);
            c.launch_in_parts(k, n, 262144);  // (a cancel between parts of 256K texels)
            read_asking(c.queue, out, 0, sizeof(float) * values, planar ? plane.data() : dst);
            if (planar)
                for (std::size_t i = 0; i < n; ++i)
                    dst[i * nch + ch] = plane[i];
        }
    } catch (const cl::Error& e) {
        throw opencl_error("bake", e);
    }
}

}  // namespace relief::host
