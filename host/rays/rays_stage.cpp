// SPDX-License-Identifier: Apache-2.0
// Radial ray integration (docs/design.md §4.2-4.3): which path a request
// takes. Periodic textures (with periodic_by_fft) integrate by one FFT
// convolution (rays_fft.cpp); clip, or periodic without it, along chains
// (rays_fast.cpp, the FFT's values inside with clip_by_fft); impl=reference
// walks every ray (rays_reference.cpp).
#include "rays/rays_stage.h"

#include <algorithm>
#include <cstdint>
#include <utility>

#include "errors.h"
#include "fft/fft_plan.h"
#include "rays/rays_parts.h"

namespace relief::host {

void integrate_rays_fast(ComputeContext& ctx, DeviceSlopes&& slopes, const RayParams& p,
                         const HeightSink& out, const Progress& progress, RayReport* report)
{
    DeviceSlopes taken = std::move(slopes);
    if (p.boundary == RayBoundary::Periodic && p.periodic_by_fft) {
        expect_ray_params(p);
        integrate_rays_by_fft(ctx, taken, true, p, out, progress, report);
        return;
    }
    integrate_rays_fast(ctx, taken, p, out(), progress, report);
}

void integrate_rays_fast(ComputeContext& ctx, const DeviceSlopes& slopes, const RayParams& p,
                         float* height_out, const Progress& progress, RayReport* report)
{
    if (p.boundary == RayBoundary::Periodic && p.periodic_by_fft) {
        expect_ray_params(p);
        DeviceSlopes shared = slopes;
        integrate_rays_by_fft(
            ctx, shared, false, p, [&] { return height_out; }, progress, report);
        return;
    }
    expect_ray_params(p);
    integrate_rays_chains(ctx, slopes, p, height_out, progress, report);
}

std::uint64_t rays_fast_device_bytes(int w, int h, const RayParams& p, bool slopes_taken)
{
    const std::uint64_t n = std::uint64_t(w) * std::uint64_t(h), slopes = 8 * n;
    const std::uint64_t grid = sizeof(float) * FftPlan::row_stride(std::size_t(w)) * std::uint64_t(h);
    // gx, gy, one kernel grid and the transform's transposed spectrum
    const std::uint64_t convolution = 4 * grid;
    if (p.boundary == RayBoundary::Periodic && p.periodic_by_fft)
        return slopes_taken ? std::max(slopes + 2 * grid, convolution) : slopes + convolution;
    // chains: sums (float4), tail and accumulator (float2), out (float);
    // clip's convolution runs first and is freed before them
    const bool fft_first = p.boundary == RayBoundary::Clip && p.clip_by_fft;
    return slopes + std::max<std::uint64_t>(36 * n, fft_first ? convolution : 0);
}

}  // namespace relief::host
