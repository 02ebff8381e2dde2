// SPDX-License-Identifier: Apache-2.0
#include "slopes/slope_stage.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "errors.h"
#include "device/opencl_context.h"
#include "device/queue_wait.h"

namespace relief::host {

namespace {

std::size_t texel_count(int w, int h)
{
    return std::size_t(w) * std::size_t(h);
}

// Sums of squared curl per row of cells, then the RMS per cell for each
// convention. Row sums are added in a fixed order, so the result does not
// depend on the device's thread count.
void measure_curl(ComputeContext::Impl& cl_, const cl::Buffer& slopes, int w, int h, SlopeStats& stats)
{
    if (w < 2 || h < 2)
        return;  // no cell: both norms stay 0 and the choice is ambiguous
    int cell_rows = h - 1;
    cl::Buffer sums = cl_.buffer(CL_MEM_WRITE_ONLY, sizeof(cl_float2) * cell_rows, "the DDM stage");
    cl::Kernel k(cl_.program("ddm.cl"), "curl_row_sums");
    set_args(k, slopes, w, cell_rows, sums);
    cl_.launch(k, cell_rows);
    std::vector<cl_float2> host(cell_rows);
    read_asking(cl_.queue, sums, 0, sizeof(cl_float2) * cell_rows, host.data());
    double gl = 0.0, dx = 0.0;
    for (const auto& s : host) {
        gl += s.s[0];
        dx += s.s[1];
    }
    double cells = double(w - 1) * double(h - 1);
    stats.curl_opengl = std::sqrt(gl / cells);
    stats.curl_directx = std::sqrt(dx / cells);
}

}  // namespace

DeviceSlopes derive_slopes(ComputeContext& ctx, const NormalRows& rows, const SlopeParams& p,
                           SlopeStats& stats)
{
    if (p.width <= 0 || p.height <= 0)
        throw Error("empty normal map");
    if (p.channels != 2 && p.channels != 3)
        throw Error("derive_slopes needs 2 or 3 values per texel");
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        const std::size_t n = texel_count(p.width, p.height);
        check_index_range(p.width, p.height, "slopes");
        const int texels = int(n);
        // The decoded map goes up in bands of rows of at most 64 MiB (and one
        // device buffer): a whole 16384^2 RGB float map passes many devices'
        // limit, and is 3 GB on the host that the file's bytes do not need.
        const std::size_t per_row = sizeof(float) * std::size_t(p.channels) * std::size_t(p.width);
        const std::size_t band_bytes = std::min<std::size_t>(c.buffer_limit(), std::size_t(64) << 20);
        const int band =
            int(std::min<std::size_t>(std::size_t(p.height), std::max<std::size_t>(band_bytes / per_row, 1)));
        cl::Buffer in = c.buffer(CL_MEM_READ_ONLY, per_row * std::size_t(band), "the DDM stage");
        std::vector<float> staging(per_row / sizeof(float) * std::size_t(band));
        auto impl = std::make_shared<DeviceSlopes::Impl>();
        impl->buffer = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * n, "the DDM stage");
        cl_int zero[2] = {0, 0};
        cl::Buffer counters =
            c.buffer(CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(zero), "the DDM stage", zero);

        // Derive with OpenGL first; DirectX is the same field with gy negated.
        const double a = p.max_angle_deg * M_PI / 180.0;
        cl::Kernel k(c.program("ddm.cl"), "ddm_slopes");
        // Arguments 2 and 3, the band's first texel and count, per launch.
        set_args(k, in, p.channels);
        set_args_at(k, 4, p.scale, p.bias, p.zero_band, -1.0f, float(std::cos(a)), float(std::sin(a)),
                    impl->buffer, counters);
        for (int first_row = 0; first_row < p.height; first_row += band) {
            const int band_rows = std::min(band, p.height - first_row);
            rows(first_row, band_rows, staging.data());
            const std::size_t first = std::size_t(first_row) * std::size_t(p.width);
            const std::size_t count = std::size_t(band_rows) * std::size_t(p.width);
            // Blocking: the next band reuses the buffer and the staging rows.
            write_asking(c.queue, in, 0, per_row * std::size_t(band_rows), staging.data());
            set_args_at(k, 2, cl_int(first), cl_int(count));
            c.launch(k, count);
        }
        read_asking(c.queue, counters, 0, sizeof(zero), zero);
        stats.invalid = zero[0];
        stats.clamped = zero[1];

        stats.chosen = p.convention;
        if (p.convention == GreenConvention::Auto) {
            measure_curl(c, impl->buffer, p.width, p.height, stats);
            stats.auto_chosen = true;
            double lo = std::min(stats.curl_opengl, stats.curl_directx);
            double hi = std::max(stats.curl_opengl, stats.curl_directx);
            stats.ambiguous = !(hi > kAmbiguousCurlRatio * lo);
            stats.chosen = (!stats.ambiguous && stats.curl_directx < stats.curl_opengl)
                               ? GreenConvention::DirectX
                               : GreenConvention::OpenGL;
        }
        if (stats.chosen == GreenConvention::DirectX) {
            cl::Kernel f(c.program("ddm.cl"), "flip_row_slope");
            set_args(f, impl->buffer, texels);
            c.launch(f, n);
        }
        finish_asking(c.queue);
        return DeviceSlopes(p.width, p.height, impl);
    } catch (const cl::Error& e) {
        throw opencl_error("slope", e);
    }
}

DeviceSlopes upload_slopes(ComputeContext& ctx, const float* slopes, int width, int height)
{
    check_index_range(width, height, "slopes");
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        auto impl = std::make_shared<DeviceSlopes::Impl>();
        impl->buffer = c.buffer(CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR,
                                sizeof(cl_float2) * texel_count(width, height), "the DDM stage", slopes);
        return DeviceSlopes(width, height, impl);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error uploading slopes: ") + e.what());
    }
}

void read_slopes(ComputeContext& ctx, const DeviceSlopes& slopes, float* out)
{
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        read_asking(c.queue, slopes.impl().buffer, 0,
                    sizeof(cl_float2) * texel_count(slopes.width(), slopes.height()), out);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error reading slopes: ") + e.what());
    }
}

void with_slopes_on_host(ComputeContext& ctx, const DeviceSlopes& slopes,
                         const std::function<void(const float*)>& use)
{
    auto& c = ctx.impl();
    std::unique_lock<std::mutex> lock(c.mutex);
    const std::size_t bytes = sizeof(cl_float2) * texel_count(slopes.width(), slopes.height());
    void* p = nullptr;
    try {
        p = map_for_reading_asking(c.queue, slopes.impl().buffer, bytes);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error mapping slopes: ") + e.what());
    }
    lock.unlock();  // `use` may take the context itself
    struct Unmap {
        ComputeContext::Impl& c;
        const cl::Buffer& b;
        void* p;
        ~Unmap()
        {
            std::lock_guard<std::mutex> l(c.mutex);
            try {
                c.queue.enqueueUnmapMemObject(b, p);
                c.queue.finish();
            } catch (const cl::Error&) {
                // nothing to report from a destructor; the buffer goes with its owner
            }
        }
    } unmap{c, slopes.impl().buffer, p};
    use(static_cast<const float*>(p));
}

}  // namespace relief::host
