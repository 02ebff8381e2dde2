// SPDX-License-Identifier: Apache-2.0
#pragma once
// Stage 2, radial ray integration (docs/design.md §4.2): slopes -> displacement.
#include <cstdint>
#include <functional>

#include "device/compute_context.h"
#include "rays/rays_walk.h"
#include "slopes/slope_stage.h"

namespace relief::host {

enum class RayBoundary { Periodic, Clip };

struct RayParams {
    int rays = 32;         // J
    double radius = 64.0;  // R, texels
    double phase = 0.5;    // phi: angles 2*pi*(j + phi)/J
    DirectionSet directions = DirectionSet::Exact;
    RayBoundary boundary = RayBoundary::Periodic;
    // Keep sums in float even where the device has fp64 (the path for
    // devices without it; tests): the fast kernel's chains with re-anchoring,
    // the reference kernel's ray sums with Kahan compensation.
    bool force_float = false;
    int float_reanchor = 32;  // chain steps between re-anchors in float
    // Skip tiles whose slopes, and all slopes within the ray radius, are
    // exactly zero (docs/design.md §6); the result is bit-identical either way.
    bool skip_flat = true;
    // Fast kernel, periodic boundary: integrate as one FFT convolution (the
    // cost of two Poisson solves, whatever J and R) rather than along chains.
    bool periodic_by_fft = true;
    // Fast kernel, clip: texels whose rays all stay in the image take the
    // FFT convolution's value (it is the same sum there); chains walk only
    // the band within the radius of the border.
    bool clip_by_fft = true;
};

// What a ray integration skipped.
struct RayReport {
    std::size_t tiles = 0;    // tiles of kSkipTile x kSkipTile texels
    std::size_t skipped = 0;  // ... whose integration was skipped
};

constexpr int kSkipTile = 32;

// Fraction done in [0, 1]; called from the calling thread between launches.
using Progress = std::function<void(double)>;

// Integrates the slope field with the reference kernel into `height_out`
// (width*height floats, texel units, bumps positive, zero mean).
void integrate_rays_reference(ComputeContext& ctx, const DeviceSlopes& slopes, const RayParams& params,
                              float* height_out, const Progress& progress = {}, RayReport* report = nullptr);

// The fast kernel (docs/design.md §4.3): same result as integrate_rays_reference
// to rounding, at a cost independent of the radius. Periodic boundaries (with
// periodic_by_fft): one FFT convolution, either direction set. Clip (or
// periodic_by_fft off): rational directions, chain windows; with
// clip_by_fft, only in the border band, the FFT's values inside it.
void integrate_rays_fast(ComputeContext& ctx, const DeviceSlopes& slopes, const RayParams& params,
                         float* height_out, const Progress& progress = {}, RayReport* report = nullptr);

// The same, taking the slopes over (as integrate_poisson's form does): the
// periodic convolution lets go of them once split into its grids and asks
// `out` for the result's memory only after its grids are gone.
void integrate_rays_fast(ComputeContext& ctx, DeviceSlopes&& slopes, const RayParams& params,
                         const HeightSink& out, const Progress& progress = {}, RayReport* report = nullptr);

// Bytes of device buffers integrate_rays_fast holds at its peak for a w x h
// map, the slopes included (`slopes_taken`: the DeviceSlopes&& form).
std::uint64_t rays_fast_device_bytes(int w, int h, const RayParams& params, bool slopes_taken);

}  // namespace relief::host
