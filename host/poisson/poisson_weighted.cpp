// SPDX-License-Identifier: Apache-2.0
// Weighted least-squares integration: preconditioned conjugate gradients on
// the device (kernels/poisson_weighted.cl), the unweighted Laplacian as the
// preconditioner. The targets carry the difference between the spectral
// (unmasked) and the discrete solution of the same slopes, so that all-ones
// weights give the unmasked answer and the answer moves continuously with
// the weights.
#include <cmath>
#include <vector>

#include "fft/dct_plan.h"
#include "errors.h"
#include "fft/fft_plan.h"
#include "field_ops.h"
#include "device/opencl_context.h"
#include "fft/plan_cache.h"
#include "poisson/poisson_layout.h"
#include "poisson/poisson_stage.h"
#include "device/queue_wait.h"

namespace relief::host {

namespace {

// Weight of the edges an excluded texel keeps: holes fill smoothly.
constexpr float kExcludedEdgeWeight = 1e-3f;

}  // namespace

void integrate_poisson_weighted(ComputeContext& ctx, const DeviceSlopes& slopes, const PoissonParams& p,
                                float* height_out, PoissonReport* report)
{
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * h;
    for (std::size_t i = 0; i < n; ++i)
        expects(p.weights[i] >= 0.0f && p.weights[i] <= 1.0f, "PoissonParams: weights in [0, 1]");
    // The preconditioner's grid is laid out as the unweighted solve's (a
    // one-texel-wide texture and a periodic y with a free x transposed).
    const PoissonLayout l = poisson_layout(w, h, p);
    const int n0 = l.n0, n1 = l.n1;
    const std::size_t stride = l.stride;
    const cl_int periodic_x = !l.free_x, periodic_y = !l.free_y;
    auto& c = ctx.impl();

    // The masked slopes s g, and their spectral (unmasked-path) solution.
    std::shared_ptr<DeviceSlopes::Impl> masked = std::make_shared<DeviceSlopes::Impl>();
    cl::Buffer weight;
    try {
        std::lock_guard<std::mutex> lock(c.mutex);
        weight = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * n,
                          "the weighted Poisson stage", p.weights);
        masked->buffer = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * n, "the weighted Poisson stage");
        cl::Kernel k(c.program("poisson_weighted.cl"), "weighted_mask_slopes");
        set_args(k, slopes.impl().buffer, weight, cl_int(n), kExcludedEdgeWeight, masked->buffer);
        c.launch(k, n);
    } catch (const cl::Error& e) {
        throw opencl_error("weighted Poisson", e);
    }
    const DeviceSlopes sg(w, h, masked);
    std::vector<float> spectral(n);
    {
        PoissonParams plain = p;
        plain.weights = nullptr;
        integrate_poisson(ctx, sg, plain, spectral.data());
    }

    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        cl::Program& prog = c.program("poisson_weighted.cl");
        auto buffer = [&](std::size_t bytes) {
            return c.buffer(CL_MEM_READ_WRITE, bytes, "the weighted Poisson stage");
        };
        cl::Buffer edge_c = buffer(sizeof(cl_float2) * n), edge_t = buffer(sizeof(cl_float2) * n);
        cl::Buffer x = c.buffer(CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(float) * n,
                                "the weighted Poisson stage", spectral.data());
        cl::Buffer r = buffer(sizeof(float) * n), z = buffer(sizeof(float) * n);
        cl::Buffer d = buffer(sizeof(float) * n), q = buffer(sizeof(float) * n);
        // The dot products' partial sums, one per work-group (summed on the
        // host in double, in order: deterministic).
        cl::Kernel dot_k(prog, "weighted_dot");
        const std::size_t dot_group = c.group_size(dot_k, sizeof(float));
        const std::size_t groups = (n + dot_group - 1) / dot_group;
        cl::Buffer partial = buffer(sizeof(float) * groups);
        cl::Buffer grid = buffer(sizeof(float) * stride * n1);
        const SpectralPlan plan(c, l.kind, n0, n1, grid);
        auto run = [&](cl::Kernel& k, std::size_t items = 0) { c.launch(k, items ? items : n); };

        cl::Kernel edges(prog, "weighted_edges");
        auto set_edges = [&](int unit) {
            // z: delta, once computed.
            set_args(edges, masked->buffer, weight, z, cl_int(w), cl_int(h), periodic_x, periodic_y,
                     kExcludedEdgeWeight, cl_int(unit), edge_c, edge_t);
            run(edges);
        };
        cl::Kernel rhs(prog, "weighted_rhs");
        set_args(rhs, edge_c, edge_t, cl_int(w), cl_int(h), periodic_x, periodic_y, r);  // r: b
        cl::Kernel apply(prog, "weighted_apply");
        // Arguments 0 and 6, what it applies to and where to, per use.
        set_args_at(apply, 1, edge_c, cl_int(w), cl_int(h), periodic_x, periodic_y);
        std::vector<float> partial_host(groups);
        auto dot = [&](cl::Buffer& a, cl::Buffer& b) {
            set_args(dot_k, a, b, cl_int(n), partial, cl::Local(sizeof(float) * dot_group));
            c.launch(dot_k, n, sizeof(float));
            read_asking(c.queue, partial, 0, sizeof(float) * groups, partial_host.data());
            double s = 0.0;
            for (float v : partial_host)
                s += v;
            return s;
        };
        cl::Kernel axpy(prog, "weighted_axpy"), xpby(prog, "weighted_xpby");
        auto add = [&](cl::Buffer& y, cl::Buffer& v, double alpha) {
            set_args(axpy, y, v, float(alpha), cl_int(n));
            run(axpy);
        };
        cl::Kernel to_grid(prog, "weighted_to_grid"), from_grid(prog, "weighted_from_grid");
        cl::Kernel divide(prog, "weighted_laplace_divide");
        auto precondition = [&]() {  // z = L^-1 r
            set_args(to_grid, r, cl_int(n0), cl_int(n1), cl_int(stride), cl_int(l.transposed), grid);
            run(to_grid, stride * std::size_t(n1));
            plan.forward(grid);
            set_args(divide, grid, cl_int(n0), cl_int(n1), cl_int(l.periodic0()), cl_int(l.periodic1()));
            run(divide, std::size_t(l.periodic0() ? n0 / 2 + 1 : n0) * n1);
            plan.inverse(grid);
            set_args(from_grid, grid, cl_int(n0), cl_int(n1), cl_int(stride), cl_int(l.transposed), z);
            run(from_grid);
        };

        // delta = FC(s g) - (the discrete solution of mean(s g)), into z.
        set_edges(1);
        run(rhs);
        precondition();                            // z = L^-1 D^T mean(s g)
        cl::Kernel negate(prog, "weighted_xpby");  // z = x + (-1) z
        set_args(negate, z, x, -1.0f, cl_int(n));
        run(negate);
        set_edges(0);
        run(rhs);  // r = b
        // Start from the spectral solution: exact when all weights are 1.
        set_args_at(apply, 0, x);
        set_args_at(apply, 6, q);
        run(apply);
        const double norm_b = std::sqrt(dot(r, r));
        add(r, q, -1.0);  // r = b - A x
        set_args_at(apply, 0, d);

        PoissonReport rep;
        rep.residual = norm_b > 0.0 ? std::sqrt(dot(r, r)) / norm_b : 0.0;
        if (norm_b > 0.0 && rep.residual > p.tolerance) {
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
                set_args(xpby, d, z, float(rz_next / rz), cl_int(n));
                run(xpby);
                rz = rz_next;
            }
            rep.iterations = std::min(rep.iterations, p.max_iterations);
        }
        if (report)
            *report = rep;
        read_asking(c.queue, x, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw opencl_error("weighted Poisson", e);
    }
    remove_mean(height_out, n);
}

}  // namespace relief::host
