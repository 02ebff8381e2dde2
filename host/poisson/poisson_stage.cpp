// SPDX-License-Identifier: Apache-2.0
#include "poisson/poisson_stage.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "errors.h"
#include "fft/dct_plan.h"
#include "fft/fft_plan.h"
#include "field_ops.h"
#include "device/opencl_context.h"
#include "fft/plan_cache.h"
#include "poisson/poisson_layout.h"

namespace relief::host {

double highpass_sigma(double highpass)
{
    return highpass > 0.0 ? highpass * std::sqrt(2.0 * std::log(2.0)) / (2.0 * M_PI) : 0.0;
}

void integrate_poisson_weighted(ComputeContext& ctx, const DeviceSlopes& slopes, const PoissonParams& p,
                                float* height_out, PoissonReport* report);

namespace {

// Both forms: `consume` lets go of `slopes` once split into the grids.
void poisson(ComputeContext& ctx, DeviceSlopes& slopes, bool consume, const PoissonParams& p,
             const HeightSink& sink, PoissonReport* report)
{
    expects(p.highpass >= 0.0 && std::isfinite(p.highpass), "PoissonParams: a highpass radius >= 0");
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    if (n == 1) {  // one texel: nothing to integrate
        sink()[0] = 0.0f;
        return;
    }
    const PoissonLayout l = poisson_layout(w, h, p);
    if (p.weights) {
        expects(p.highpass == 0.0, "PoissonParams: no highpass with weights");
        integrate_poisson_weighted(ctx, slopes, p, sink(), report);
        return;
    }
    const int n0 = l.n0, n1 = l.n1;
    if (const std::string why = FftPlan::unsupported(n0, n1); !why.empty())
        throw Error("least squares: " + why);  // before anything is made
    const std::size_t stride = l.stride;
    const std::size_t bytes = sizeof(float) * stride * n1;
    const float sigma = float(highpass_sigma(p.highpass));

    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    float* height_out = nullptr;
    try {
        cl::Program& prog = c.program("poisson.cl");
        cl::Buffer gx = c.buffer(CL_MEM_READ_WRITE, bytes, "the Poisson stage");
        cl::Buffer gy = c.buffer(CL_MEM_READ_WRITE, bytes, "the Poisson stage");

        cl::Kernel split(prog, "poisson_split");
        set_args(split, slopes.impl().buffer, cl_int(w), cl_int(n0), cl_int(n1), cl_int(l.transposed),
                 cl_int(stride), cl_int(!l.periodic0()), cl_int(!l.periodic1()), gx, gy);
        c.launch(split, stride * std::size_t(n1));
        if (consume) {
            split = cl::Kernel();  // the kernel holds its arguments too
            slopes.release();      // freed once the split has run
        }
        // The plans' own buffers are made after the slopes are gone.
        std::optional<SpectralPlan> plan;
        plan.emplace(c, l.kind, n0, n1, gx);
        plan->forward(gx);
        plan->forward(gy);

        // In place on gx's spectrum (the free kernel pairs k with n0 - k).
        cl::Kernel divide(prog, l.kind == SpectralKind::Fourier  ? "poisson_periodic_divide"
                                : l.kind == SpectralKind::Cosine ? "poisson_free_divide"
                                                                 : "poisson_mixed_divide");
        set_args(divide, gx, gy, cl_int(n0), cl_int(n1), sigma);
        c.launch(divide, std::size_t(n0 / 2 + 1) * n1);
        plan->inverse(gx);
        divide = cl::Kernel();
        plan.reset();

        height_out = read_real_result(c, gx, gy, stride, w, h, l.transposed, sink);
    } catch (const cl::Error& e) {
        throw opencl_error("Poisson", e);
    }
    // The transforms already drop the mean; this removes their rounding.
    remove_mean(height_out, n);
}

}  // namespace

void integrate_poisson(ComputeContext& ctx, const DeviceSlopes& slopes, const PoissonParams& p,
                       float* height_out, PoissonReport* report)
{
    DeviceSlopes shared = slopes;
    poisson(
        ctx, shared, false, p, [&] { return height_out; }, report);
}

void integrate_poisson(ComputeContext& ctx, DeviceSlopes&& slopes, const PoissonParams& p,
                       const HeightSink& out, PoissonReport* report)
{
    DeviceSlopes taken = std::move(slopes);
    poisson(ctx, taken, true, p, out, report);
}

std::uint64_t poisson_device_bytes(int w, int h, const PoissonParams& p, bool slopes_taken)
{
    const std::uint64_t n = std::uint64_t(w) * std::uint64_t(h), slopes = 8 * n;
    if (p.weights)  // conjugate gradients: masked slopes, edges, CG vectors (poisson_weighted.cpp)
        return slopes + 16 * sizeof(float) * n;
    const PoissonLayout l = poisson_layout(w, h, p);
    const std::uint64_t grid = sizeof(float) * l.stride * std::uint64_t(l.n1);
    // gx, gy and the transposed spectrum (a DCT adds its reordered copy);
    // taken, the slopes are gone before the transforms' buffers are made
    const std::uint64_t grids = (l.kind == SpectralKind::Fourier ? 3 : 4) * grid;
    return slopes_taken ? std::max(slopes + 2 * grid, grids) : slopes + grids;
}

}  // namespace relief::host
