// Weighted least-squares integration: conjugate gradients on the device
// (kernels/poisson_weighted.cl) in the Riesz form of the spectral problem,
// so that weights of all ones give the unmasked Frankot–Chellappa answer.
#include <cmath>
#include <optional>
#include <vector>

#include "dct_plan.h"
#include "errors.h"
#include "fft_plan.h"
#include "field_ops.h"
#include "opencl_context.h"
#include "poisson_stage.h"

namespace relief::host {

namespace {

// Weight an excluded texel keeps (with target 0): holes fill smoothly.
constexpr float kExcludedWeight = 1e-3f;

} // namespace

void integrate_poisson_weighted(ComputeContext& ctx, const DeviceSlopes& slopes,
                                const PoissonParams& p, float* height_out, PoissonReport* report)
{
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * h;
    for (std::size_t i = 0; i < n; ++i)
        if (!(p.weights[i] >= 0.0f && p.weights[i] <= 1.0f))
            throw Error("mask weights must be in [0, 1] (texel " + std::to_string(i) + ")");
    const bool periodic = p.boundary == PoissonBoundary::Periodic;
    // A one-texel-wide texture is solved transposed, as in poisson_stage.
    const bool transposed = w == 1;
    const int n0 = transposed ? h : w, n1 = transposed ? 1 : h;
    const std::size_t stride =
        periodic ? FftPlan::row_stride(n0) : std::size_t(n0);
    const std::size_t bins = periodic ? std::size_t(n0 / 2 + 1) * n1 : n;
    const std::size_t groups = padded(n) / kGroupSize;

    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        cl::Program& prog = c.program("poisson_weighted.cl");
        auto buffer = [&](std::size_t bytes) {
            return c.buffer(CL_MEM_READ_WRITE, bytes, "the weighted Poisson stage");
        };
        cl::Buffer weight = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * n, "the weighted Poisson stage", p.weights);
        cl::Buffer cw = buffer(sizeof(float) * n), target = buffer(sizeof(cl_float2) * n);
        cl::Buffer x = buffer(sizeof(float) * n), r = buffer(sizeof(float) * n);
        cl::Buffer d = buffer(sizeof(float) * n), q = buffer(sizeof(float) * n);
        cl::Buffer partial = buffer(sizeof(float) * groups);
        cl::Buffer gu = buffer(sizeof(float) * stride * n1), gx = buffer(sizeof(float) * stride * n1),
                   gy = buffer(sizeof(float) * stride * n1);
        std::optional<FftPlan> fft;
        std::optional<DctPlan> dct;
        if (periodic)
            fft.emplace(c, n0, n1);
        else
            dct.emplace(c, n0, n1);
        auto forward = [&](cl::Buffer& b) { periodic ? fft->forward(b) : dct->forward(b); };
        auto inverse = [&](cl::Buffer& b) { periodic ? fft->inverse(b) : dct->inverse(b); };
        auto run = [&](cl::Kernel& k, std::size_t items) {
            c.queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(padded(items)),
                                         cl::NDRange(kGroupSize));
        };

        cl::Kernel targets(prog, "weighted_targets");
        targets.setArg(0, slopes.impl().buffer);
        targets.setArg(1, weight);
        targets.setArg(2, cl_int(n));
        targets.setArg(3, cl_int(transposed));
        targets.setArg(4, kExcludedWeight);
        targets.setArg(5, cw);
        targets.setArg(6, target);
        run(targets, n);

        cl::Kernel to_grid(prog, "weighted_to_grid"), from_grid(prog, "weighted_from_grid");
        for (cl::Kernel* k : {&to_grid, &from_grid}) {
            k->setArg(1, cl_int(n0));
            k->setArg(2, cl_int(n1));
            k->setArg(3, cl_int(stride));
        }
        cl::Kernel riesz(prog, "weighted_riesz"), adjoint(prog, "weighted_riesz_adjoint");
        riesz.setArg(0, gu);  // (u, n0, n1, periodic, gx, gy)
        riesz.setArg(1, cl_int(n0));
        riesz.setArg(2, cl_int(n1));
        riesz.setArg(3, cl_int(periodic));
        riesz.setArg(4, gx);
        riesz.setArg(5, gy);
        adjoint.setArg(0, gx);  // (gx, gy, n0, n1, periodic, u)
        adjoint.setArg(1, gy);
        adjoint.setArg(2, cl_int(n0));
        adjoint.setArg(3, cl_int(n1));
        adjoint.setArg(4, cl_int(periodic));
        adjoint.setArg(5, gu);
        cl::Kernel scale(prog, "weighted_scale");
        scale.setArg(0, gx);
        scale.setArg(1, gy);
        scale.setArg(2, cw);
        scale.setArg(3, cl_int(n0));
        scale.setArg(4, cl_int(n1));
        scale.setArg(5, cl_int(stride));

        // out = R* (gx, gy) for real-space fields in gx, gy.
        auto apply_adjoint = [&](cl::Buffer& out) {
            forward(gx);
            forward(gy);
            run(adjoint, bins);
            inverse(gu);
            from_grid.setArg(0, gu);
            from_grid.setArg(4, out);
            run(from_grid, n);
        };
        // out = R* C R v
        auto apply = [&](cl::Buffer& v, cl::Buffer& out) {
            to_grid.setArg(0, v);
            to_grid.setArg(4, gu);
            run(to_grid, n);
            forward(gu);
            run(riesz, bins);
            inverse(gx);
            inverse(gy);
            run(scale, n);
            apply_adjoint(out);
        };

        cl::Kernel load(prog, "weighted_load_targets");
        load.setArg(0, cw);
        load.setArg(1, target);
        load.setArg(2, cl_int(n0));
        load.setArg(3, cl_int(n1));
        load.setArg(4, cl_int(stride));
        load.setArg(5, cl_int(!periodic));
        load.setArg(6, gx);
        load.setArg(7, gy);
        run(load, n);
        apply_adjoint(r);  // x = 0, so r = b = R* C t
        c.queue.enqueueFillBuffer(x, 0.0f, 0, sizeof(float) * n);

        cl::Kernel dot_k(prog, "weighted_dot");
        std::vector<float> partial_host(groups);
        auto dot = [&](cl::Buffer& a, cl::Buffer& b) {
            dot_k.setArg(0, a);
            dot_k.setArg(1, b);
            dot_k.setArg(2, cl_int(n));
            dot_k.setArg(3, partial);
            run(dot_k, n);
            c.queue.enqueueReadBuffer(partial, CL_TRUE, 0, sizeof(float) * groups,
                                      partial_host.data());
            double s = 0.0;
            for (float v : partial_host)
                s += v;
            return s;
        };
        cl::Kernel axpy(prog, "weighted_axpy"), xpby(prog, "weighted_xpby");
        auto add = [&](cl::Buffer& y, cl::Buffer& v, double alpha) {
            axpy.setArg(0, y);
            axpy.setArg(1, v);
            axpy.setArg(2, float(alpha));
            axpy.setArg(3, cl_int(n));
            run(axpy, n);
        };

        PoissonReport rep;
        double rr = dot(r, r);
        const double norm_b = std::sqrt(rr);
        if (norm_b > 0.0) {
            c.queue.enqueueCopyBuffer(r, d, 0, 0, sizeof(float) * n);
            for (rep.iterations = 1; rep.iterations <= p.max_iterations; ++rep.iterations) {
                apply(d, q);
                const double dq = dot(d, q);
                if (!(dq > 0.0))
                    break;  // converged to rounding (d in the null space)
                const double alpha = rr / dq;
                add(x, d, alpha);
                add(r, q, -alpha);
                const double rr_next = dot(r, r);
                rep.residual = std::sqrt(rr_next) / norm_b;
                if (rep.residual <= p.tolerance)
                    break;
                xpby.setArg(0, d);
                xpby.setArg(1, r);
                xpby.setArg(2, float(rr_next / rr));
                xpby.setArg(3, cl_int(n));
                run(xpby, n);
                rr = rr_next;
            }
            rep.iterations = std::min(rep.iterations, p.max_iterations);
        }
        if (report)
            *report = rep;

        // h = L^{-1/2} x
        to_grid.setArg(0, x);
        to_grid.setArg(4, gu);
        run(to_grid, n);
        forward(gu);
        cl::Kernel unriesz(prog, "weighted_unriesz");
        unriesz.setArg(0, gu);
        unriesz.setArg(1, cl_int(n0));
        unriesz.setArg(2, cl_int(n1));
        unriesz.setArg(3, cl_int(periodic));
        run(unriesz, bins);
        inverse(gu);
        from_grid.setArg(0, gu);
        from_grid.setArg(4, x);
        run(from_grid, n);
        c.queue.enqueueReadBuffer(x, CL_TRUE, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the weighted Poisson stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }
    remove_mean(height_out, n);
}

} // namespace relief::host
