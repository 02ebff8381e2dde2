// SPDX-License-Identifier: Apache-2.0
#pragma once
// Checking a result (docs/design.md §9, kernels/check.cl): a height's normals,
// its round trip against the slopes it came from, tessellation levels.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "device/compute_context.h"
#include "slopes/slope_stage.h"

namespace relief::host {

// h: w*ht heights (texels). out: 3 floats per texel, the unit normal of
// scale*h by central differences (wrapping along a periodic axis, one-sided
// at the edges of a free one), its row component stored as -n_y (OpenGL) or
// +n_y (DirectX).
void height_normals(ComputeContext& ctx, const float* h, int w, int ht, bool periodic_x, bool periodic_y,
                    float scale, bool directx, float* out);

struct RoundTrip {
    double mean_deg = 0.0, p95_deg = 0.0, max_deg = 0.0;  // angle between the normals
    double residual_share = 0.0;                          // sum |g - grad h|^2 / sum |g|^2 (0 when g is 0)
    std::vector<float> angle_deg;                         // per texel, when asked for
};

// The height h (w*ht, the size of `slopes`) against the slopes it came from,
// with the differences of height_normals(). Sums in double on the host, in
// texel order: the same bits whatever the device's thread count.
RoundTrip round_trip(ComputeContext& ctx, const DeviceSlopes& slopes, const float* h, bool periodic_x,
                     bool periodic_y, bool keep_angles = false);

constexpr int kMaxTessellationLevel = 64;

// How tessellation_levels() spreads the work: one work-item per patch
// (scanning the levels upward), or one per patch and level. Auto: per
// patch when there are at least kPatchesForPerPatch patches (enough to fill
// a device), else per patch and level. Both give the same levels. Per
// patch is taken only where the device lets a work-item loop over every
// level (ComputeContext::Impl::loops_fit; not on Mesa's llvmpipe beyond
// 31-texel patches); patches too large for even one level there are
// refused.
enum class TessellationLaunch { Auto, PerPatch, PerLevel };
constexpr std::size_t kPatchesForPerPatch = 4096;

// Per patch of patch x patch texels (row-major, ceil(w/patch) x
// ceil(ht/patch)): the lowest level in 1..64 whose uniform tessellation of
// scale*h stays within `error` at every texel centre, or 0 when none does.
std::vector<std::uint8_t> tessellation_levels(ComputeContext& ctx, const float* h, int w, int ht, int patch,
                                              float error, float scale,
                                              TessellationLaunch launch = TessellationLaunch::Auto);

}  // namespace relief::host
