// Weighted least-squares integration: preconditioned conjugate gradients on
// the device (kernels/poisson_weighted.cl), the unweighted Laplacian as the
// preconditioner, inverted by VkFFT transforms.
#include <cmath>
#include <vector>

#include "errors.h"
#include "fft_plan.h"
#include "field_ops.h"
#include "opencl_context.h"
#include "poisson_stage.h"

namespace relief::host {

namespace {

// Weight of the edges an excluded texel keeps: holes fill smoothly.
constexpr float kExcludedEdgeWeight = 1e-3f;

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
    // The Laplacian of a one-texel-wide texture is the same path graph
    // whichever way round; the transforms want it along axis 0.
    const int n0 = w == 1 ? h : w, n1 = w == 1 ? 1 : h;
    const auto kind = periodic ? FftPlan::Kind::RealToComplex : FftPlan::Kind::Dct2;
    const std::size_t stride = FftPlan::row_stride(kind, n0);
    const std::size_t groups = padded(n) / kGroupSize;

    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        cl::Program& prog = c.program("poisson_weighted.cl");
        auto buffer = [&](std::size_t bytes) { return cl::Buffer(c.context, CL_MEM_READ_WRITE, bytes); };
        cl::Buffer weight(c.context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * n,
                          const_cast<float*>(p.weights));
        cl::Buffer edge_c = buffer(sizeof(cl_float2) * n), edge_t = buffer(sizeof(cl_float2) * n);
        cl::Buffer x = buffer(sizeof(float) * n), r = buffer(sizeof(float) * n);
        cl::Buffer z = buffer(sizeof(float) * n), d = buffer(sizeof(float) * n);
        cl::Buffer q = buffer(sizeof(float) * n), partial = buffer(sizeof(float) * groups);
        cl::Buffer grid = buffer(sizeof(float) * stride * n1);
        FftPlan plan(c.context, c.device, kind, n0, n1, grid);
        const cl::NDRange global(padded(n)), local(kGroupSize);
        auto run = [&](cl::Kernel& k, std::size_t items = 0) {
            c.queue.enqueueNDRangeKernel(k, cl::NullRange, items ? cl::NDRange(padded(items)) : global,
                                         local);
        };

        cl::Kernel edges(prog, "weighted_edges");
        edges.setArg(0, slopes.impl().buffer);
        edges.setArg(1, weight);
        edges.setArg(2, cl_int(w));
        edges.setArg(3, cl_int(h));
        edges.setArg(4, cl_int(periodic));
        edges.setArg(5, kExcludedEdgeWeight);
        edges.setArg(6, edge_c);
        edges.setArg(7, edge_t);
        run(edges);
        cl::Kernel rhs(prog, "weighted_rhs");
        rhs.setArg(0, edge_c);
        rhs.setArg(1, edge_t);
        rhs.setArg(2, cl_int(w));
        rhs.setArg(3, cl_int(h));
        rhs.setArg(4, cl_int(periodic));
        rhs.setArg(5, r);  // x = 0, so r = b
        run(rhs);
        c.queue.enqueueFillBuffer(x, 0.0f, 0, sizeof(float) * n);

        cl::Kernel apply(prog, "weighted_apply");
        apply.setArg(0, d);
        apply.setArg(1, edge_c);
        apply.setArg(2, cl_int(w));
        apply.setArg(3, cl_int(h));
        apply.setArg(4, cl_int(periodic));
        apply.setArg(5, q);
        cl::Kernel dot_k(prog, "weighted_dot");
        std::vector<float> partial_host(groups);
        auto dot = [&](cl::Buffer& a, cl::Buffer& b) {
            dot_k.setArg(0, a);
            dot_k.setArg(1, b);
            dot_k.setArg(2, cl_int(n));
            dot_k.setArg(3, partial);
            run(dot_k);
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
            run(axpy);
        };
        cl::Kernel to_grid(prog, "weighted_to_grid"), from_grid(prog, "weighted_from_grid");
        cl::Kernel divide(prog, "weighted_laplace_divide");
        auto precondition = [&]() {  // z = L^-1 r
            to_grid.setArg(0, r);
            to_grid.setArg(1, cl_int(n0));
            to_grid.setArg(2, cl_int(n1));
            to_grid.setArg(3, cl_int(stride));
            to_grid.setArg(4, grid);
            run(to_grid);
            plan.forward(c.queue, grid);
            divide.setArg(0, grid);
            divide.setArg(1, cl_int(n0));
            divide.setArg(2, cl_int(n1));
            divide.setArg(3, cl_int(periodic));
            run(divide, std::size_t(periodic ? n0 / 2 + 1 : n0) * n1);
            plan.inverse(c.queue, grid);
            from_grid.setArg(0, grid);
            from_grid.setArg(1, cl_int(n0));
            from_grid.setArg(2, cl_int(n1));
            from_grid.setArg(3, cl_int(stride));
            from_grid.setArg(4, z);
            run(from_grid);
        };

        const double norm_b = std::sqrt(dot(r, r));
        PoissonReport rep;
        if (norm_b > 0.0) {
            precondition();
            c.queue.enqueueCopyBuffer(z, d, 0, 0, sizeof(float) * n);
            double rz = dot(r, z);
            for (rep.iterations = 1; rep.iterations <= p.max_iterations; ++rep.iterations) {
                run(apply);  // q = A d
                const double dq = dot(d, q);
                if (!(dq > 0.0))
                    break;  // converged to rounding (d in the null space)
                const double alpha = rz / dq;
                add(x, d, alpha);
                add(r, q, -alpha);
                rep.residual = std::sqrt(dot(r, r)) / norm_b;
                if (rep.residual <= p.tolerance)
                    break;
                precondition();
                const double rz_next = dot(r, z);
                xpby.setArg(0, d);
                xpby.setArg(1, z);
                xpby.setArg(2, float(rz_next / rz));
                xpby.setArg(3, cl_int(n));
                run(xpby);
                rz = rz_next;
            }
            rep.iterations = std::min(rep.iterations, p.max_iterations);
        }
        if (report)
            *report = rep;
        c.queue.enqueueReadBuffer(x, CL_TRUE, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the weighted Poisson stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }
    remove_mean(height_out, n);
}

} // namespace relief::host
