// SPDX-License-Identifier: Apache-2.0
// Radial ray integration of periodic textures as one circular convolution
// (docs/design.md §4.3; kernels/rays_fft.cl): the cost of two Poisson solves,
// whatever the number of rays and their radius.
#include <algorithm>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include "errors.h"
#include "field_ops.h"
#include "rays/rays_parts.h"
#include "fft/fft_plan.h"
#include "fft/plan_cache.h"
#include "device/queue_wait.h"

namespace relief::host {

// A = Kx (x) gx + Ky (x) gy, one circular convolution: the periodic
// result before its mean is removed, and the clip result wherever every ray
// stays in the image. The caller holds c.mutex. With `consume`, the slopes
// are let go once split into the transform's grids; the host memory for
// the result is asked of `sink` only after the grids are gone.
void fft_ray_sums(ComputeContext::Impl& c, DeviceSlopes& slopes, bool consume, const RayParams& p,
                  const HeightSink& sink, const Progress& progress)
{
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * h;
    if (n == 1) {
        sink()[0] = 0.0f;
        return;
    }
    // A one-texel-wide texture is a 1-D transform along y (as in Poisson).
    const bool transposed = w == 1;
    const int n0 = transposed ? h : w, n1 = transposed ? 1 : h;
    if (const std::string why = FftPlan::unsupported(n0, n1); !why.empty())
        throw Error("periodic rays: " + why + " (boundary=clip walks every ray instead)");
    const std::size_t stride = FftPlan::row_stride(n0);
    const std::size_t grid = stride * n1;

    // The kernels, mirrored (K'(o) = K(-o)) so that A = K' * g, wrapped.
    // They have a few taps per walk step: kept sparse, summed per tap in
    // walk order (in double), and scattered into a grid on the device one
    // at a time, rather than made as full grids here.
    std::unordered_map<std::size_t, std::size_t> slot;  // grid index -> tap
    std::vector<std::size_t> tap_index;
    std::vector<double> tap_x, tap_y;
    double total = 0.0;
    for_each_packed_direction(
        p, [&](int, const std::vector<cl_int2>& offsets, const std::vector<cl_float4>& data) {
            const std::size_t segs = data.size();
            const double dir_total = segs ? data[segs - 1].s[3] : 0.0;  // cumulative
            for (std::size_t s = 0; s < segs; ++s) {
                const double weight = data[s].s[2];
                const double after = dir_total - data[s].s[3];  // later segments' weights
                const double factor = 0.5 * weight + after;
                const int ox = ((-offsets[s].s[0]) % w + w) % w;
                const int oy = ((-offsets[s].s[1]) % h + h) % h;
                const std::size_t at = transposed ? std::size_t(oy) : std::size_t(oy) * stride + ox;
                auto [it, added] = slot.emplace(at, tap_index.size());
                if (added) {
                    tap_index.push_back(at);
                    tap_x.push_back(0.0);
                    tap_y.push_back(0.0);
                }
                tap_x[it->second] += data[s].s[0] * factor;
                tap_y[it->second] += data[s].s[1] * factor;
            }
            total += dir_total;
        });
    if (!(total > 0.0)) {
        std::fill_n(sink(), n, 0.0f);
        return;
    }
    const std::size_t taps = tap_index.size();
    std::vector<cl_int> index(taps);
    std::vector<float> value_x(taps), value_y(taps);
    for (std::size_t t = 0; t < taps; ++t) {
        index[t] = cl_int(tap_index[t]);
        value_x[t] = float(tap_x[t]);
        value_y[t] = float(tap_y[t]);
    }
    try {
        cl::Program& spectral = c.program("poisson.cl");  // split and gather
        cl::Program& prog = c.program("rays_fft.cl");
        const std::size_t bytes = sizeof(float) * grid;
        cl::Buffer gx = c.buffer(CL_MEM_READ_WRITE, bytes, "ray integration");
        cl::Buffer gy = c.buffer(CL_MEM_READ_WRITE, bytes, "ray integration");

        cl::Kernel split(spectral, "poisson_split");
        set_args(split, slopes.impl().buffer, cl_int(w), cl_int(n0), cl_int(n1), cl_int(transposed),
                 cl_int(stride), cl_int(0), cl_int(0), gx, gy);
        c.launch(split, stride * std::size_t(n1));
        if (consume) {
            split = cl::Kernel();  // the kernel holds its arguments too
            slopes.release();      // freed once the split has run
        }
        std::shared_ptr<FftPlan> plan = c.plans->fft(c, n0, n1, gx);
        plan->forward(gx);
        plan->forward(gy);

        // Transposed, the split put the y slopes in gx and the x slopes in gy.
        const std::vector<float>& first = transposed ? value_y : value_x;
        const std::vector<float>& second = transposed ? value_x : value_y;
        cl::Buffer taps_at = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(cl_int) * taps,
                                      "ray integration", index.data());
        cl::Buffer kernel_grid = c.buffer(CL_MEM_READ_WRITE, bytes, "ray integration");
        cl::Kernel scatter(prog, "rays_fft_scatter");
        set_args(scatter, kernel_grid, taps_at);
        set_args_at(scatter, 3, cl_int(taps));
        auto make_kernel_spectrum = [&](const std::vector<float>& values) {
            cl::Buffer v = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * taps,
                                    "ray integration", values.data());
            c.fill(kernel_grid, 0.0f, 0, bytes);
            set_args_at(scatter, 2, v);
            c.launch(scatter, taps);
            plan->forward(kernel_grid);
        };
        const std::size_t count = (stride / 2) * n1;
        make_kernel_spectrum(first);
        cl::Kernel multiply(prog, "rays_fft_multiply");
        set_args(multiply, gx, kernel_grid, cl_int(count));
        c.launch(multiply, count);
        if (progress) {
            finish_asking(c.queue);
            progress(0.5);
        }
        make_kernel_spectrum(second);
        cl::Kernel multiply_add(prog, "rays_fft_multiply_add");
        set_args(multiply_add, gx, gy, kernel_grid, cl_int(count), cl_float(-1.0 / total));
        c.launch(multiply_add, count);
        plan->inverse(gx);
        scatter = multiply = multiply_add = cl::Kernel();
        kernel_grid = cl::Buffer();
        plan.reset();

        read_real_result(c, gx, gy, stride, w, h, transposed, sink);
        if (progress)
            progress(1.0);
    } catch (const cl::Error& e) {
        throw opencl_error("FFT ray", e);
    }
}

// Periodic boundaries: the convolution, then the mean removed.
void integrate_rays_by_fft(ComputeContext& ctx, DeviceSlopes& slopes, bool consume, const RayParams& p,
                           const HeightSink& sink, const Progress& progress, RayReport* report)
{
    if (report)
        *report = RayReport{};
    float* out = nullptr;
    {
        std::lock_guard<std::mutex> lock(ctx.impl().mutex);
        fft_ray_sums(
            ctx.impl(), slopes, consume, p, [&] { return out = sink(); }, progress);
    }
    remove_mean(out, std::size_t(slopes.width()) * slopes.height());
}

}  // namespace relief::host
