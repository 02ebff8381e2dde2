// SPDX-License-Identifier: Apache-2.0
#include "check/check_stage.h"

#include <algorithm>
#include <cmath>

#include "errors.h"
#include "device/opencl_context.h"
#include "device/queue_wait.h"

namespace relief::host {

namespace {

std::size_t texels(int w, int ht)
{
    if (w < 1 || ht < 1)
        throw Error("checking a result needs a non-empty height map");
    check_index_range(w, ht, "the check stage");
    return std::size_t(w) * std::size_t(ht);
}

}  // namespace

void height_normals(ComputeContext& ctx, const float* h, int w, int ht, bool periodic_x, bool periodic_y,
                    float scale, bool directx, float* out)
{
    const std::size_t n = texels(w, ht);
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        cl::Buffer in =
            c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * n, "the normals", h);
        cl::Buffer normals = c.buffer(CL_MEM_WRITE_ONLY, 3 * sizeof(float) * n, "the normals");
        cl::Kernel k(c.program("check.cl"), "height_normals");
        set_args(k, in, cl_int(w), cl_int(ht), cl_int(periodic_x), cl_int(periodic_y), cl_float(scale),
                 cl_float(directx ? 1.0f : -1.0f), normals);
        c.launch(k, n);
        read_asking(c.queue, normals, 0, 3 * sizeof(float) * n, out);
    } catch (const cl::Error& e) {
        throw opencl_error("check", e);
    }
}

RoundTrip round_trip(ComputeContext& ctx, const DeviceSlopes& slopes, const float* h, bool periodic_x,
                     bool periodic_y, bool keep_angles)
{
    const int w = slopes.width(), ht = slopes.height();
    const std::size_t n = texels(w, ht);
    std::vector<float> angle(n), residual(2 * n);
    {
        auto& c = ctx.impl();
        std::lock_guard<std::mutex> lock(c.mutex);
        try {
            cl::Buffer in =
                c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * n, "the round trip", h);
            cl::Buffer a = c.buffer(CL_MEM_WRITE_ONLY, sizeof(float) * n, "the round trip");
            cl::Buffer r = c.buffer(CL_MEM_WRITE_ONLY, 2 * sizeof(float) * n, "the round trip");
            cl::Kernel k(c.program("check.cl"), "round_trip");
            set_args(k, slopes.impl().buffer, in, cl_int(w), cl_int(ht), cl_int(periodic_x),
                     cl_int(periodic_y), a, r);
            c.launch(k, n);
            read_asking(c.queue, a, 0, sizeof(float) * n, angle.data());
            read_asking(c.queue, r, 0, 2 * sizeof(float) * n, residual.data());
        } catch (const cl::Error& e) {
            throw opencl_error("check", e);
        }
    }
    RoundTrip t;
    double sum = 0.0, misfit = 0.0, energy = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        sum += angle[i];
        t.max_deg = std::max(t.max_deg, double(angle[i]));
        misfit += residual[2 * i];
        energy += residual[2 * i + 1];
    }
    t.mean_deg = sum / double(n);
    t.residual_share = energy > 0.0 ? misfit / energy : 0.0;
    if (keep_angles)
        t.angle_deg = angle;
    // The 95th percentile: the value of rank ceil(0.95 n) (nearest rank).
    const std::size_t rank = std::size_t(std::ceil(0.95 * double(n))) - 1;
    std::nth_element(angle.begin(), angle.begin() + std::ptrdiff_t(rank), angle.end());
    t.p95_deg = angle[rank];
    return t;
}

std::vector<std::uint8_t> tessellation_levels(ComputeContext& ctx, const float* h, int w, int ht, int patch,
                                              float error, float scale, TessellationLaunch launch)
{
    const std::size_t n = texels(w, ht);
    expects(patch >= 1, "a tessellation patch of at least 1 texel");
    const int px = (w + patch - 1) / patch, py = (ht + patch - 1) / patch;
    // At most w x h patches, which texels() keeps under 2^31 for the kernel.
    const std::size_t patches = std::size_t(px) * std::size_t(py);
    // A work-item's loops: per patch, the flat test and up to every level
    // (each a pass over the patch's rows and texels); per level, one of them.
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    const std::uint64_t pass = std::uint64_t(patch) * std::uint64_t(patch) + std::uint64_t(patch);
    const bool patch_fits = c.loops_fit(pass * std::uint64_t(kMaxTessellationLevel + 1));
    if (!c.loops_fit(2 * pass))
        throw Error("tessellation patches of " + std::to_string(patch) + " texels need " +
                    std::to_string(2 * pass) +
                    " loop iterations per work-item, more than this "
                    "device lets a work-item loop (it stops loops after " +
                    std::to_string(c.loop_limit()) +
                    " iterations, as Mesa's llvmpipe does); use a "
                    "smaller patch or another OpenCL device");
    // Per patch only where the device lets its work-items loop that long.
    const bool per_patch =
        patch_fits && (launch == TessellationLaunch::PerPatch ||
                       (launch == TessellationLaunch::Auto && patches >= kPatchesForPerPatch));
    // Few patches: 64 work-items each (patches x 64 stays far below 2^31).
    const std::size_t items = per_patch ? patches : patches * kMaxTessellationLevel;
    std::vector<std::uint8_t> out_bytes(items);
    {
        try {
            cl::Buffer in = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * n,
                                     "the tessellation levels", h);
            cl::Buffer out = c.buffer(CL_MEM_WRITE_ONLY, items, "the tessellation levels");
            cl::Kernel k(c.program("check.cl"), per_patch ? "tessellation_levels" : "tessellation_pass");
            set_args(k, in, cl_int(w), cl_int(ht), cl_int(patch), cl_float(error), cl_float(scale),
                     cl_int(px), cl_int(patches), out);
            // In parts of about 64K texels' patches (18 ms each at 1024^2 on
            // two CPU cores; the whole map took 285 ms as one launch).
            const std::uint64_t texels_per_item =
                std::uint64_t(patch) * std::uint64_t(patch) / (per_patch ? 1 : kMaxTessellationLevel);
            c.launch_in_parts(
                k, items,
                std::size_t(std::max<std::uint64_t>(65536 / std::max<std::uint64_t>(texels_per_item, 1), 1)));
            read_asking(c.queue, out, 0, items, out_bytes.data());
        } catch (const cl::Error& e) {
            throw opencl_error("check", e);
        }
    }
    if (per_patch)
        return out_bytes;
    std::vector<std::uint8_t> levels(patches, 0);
    for (std::size_t p = 0; p < patches; ++p)
        for (int L = 1; L <= kMaxTessellationLevel; ++L)
            if (out_bytes[p * kMaxTessellationLevel + std::size_t(L - 1)]) {
                levels[p] = std::uint8_t(L);
                break;
            }
    return levels;
}

}  // namespace relief::host
