// SPDX-License-Identifier: Apache-2.0
#pragma once
// Stage 2, least-squares (Poisson) integration (docs/design.md §4.4):
// slopes -> height, by Frankot–Chellappa projection with FFTs along the
// periodic axes and DCTs along the free ones, on the device.
#include <cstdint>

#include "device/compute_context.h"
#include "slopes/slope_stage.h"

namespace relief::host {

enum class PoissonBoundary { Periodic, Free };

struct PoissonParams {
    // Along x (the map wraps from its right edge to its left) and y. An
    // axis one texel long has no boundary: it takes the other axis's.
    PoissonBoundary boundary_x = PoissonBoundary::Periodic, boundary_y = PoissonBoundary::Periodic;
    // Relief balance: removes structure larger than this many texels (the
    // solution minus its Gaussian blur with sigma = highpass*sqrt(2 ln 2)/(2 pi),
    // which halves the amplitude at wavelength `highpass`). 0 = off.
    double highpass = 0.0;
    // Per-texel confidence weights in [0, 1] (width*height, 0 = excluded),
    // or null. With weights the solve is the weighted discrete least squares
    // of poisson_weighted.cl by conjugate gradients; highpass is then not
    // available.
    const float* weights = nullptr;
    double tolerance = 1e-5;  // CG: stop at |r| <= tolerance * |b|
    int max_iterations = 500;
};

// What the weighted solver did.
struct PoissonReport {
    int iterations = 0;
    double residual = 0.0;  // final |r| / |b|
};

// Integrates the slopes into `height_out` (width*height floats, texel units,
// zero mean).
void integrate_poisson(ComputeContext& ctx, const DeviceSlopes& slopes, const PoissonParams& params,
                       float* height_out, PoissonReport* report = nullptr);

// The same, taking the slopes over: their buffer is let go as soon as the
// transforms have their own copy, and `out` is asked for the result's memory
// only when the transforms' grids are gone. The peak then holds the slopes
// (8 bytes a texel) or the result (4), never both beside the grids.
void integrate_poisson(ComputeContext& ctx, DeviceSlopes&& slopes, const PoissonParams& params,
                       const HeightSink& out, PoissonReport* report = nullptr);

// Bytes of device buffers integrate_poisson holds at its peak for a w x h
// map, the slopes included (`slopes_taken`: the DeviceSlopes&& form).
std::uint64_t poisson_device_bytes(int w, int h, const PoissonParams& params, bool slopes_taken);

// Gaussian sigma (texels) of the relief-balance filter for `highpass` texels.
double highpass_sigma(double highpass);

// Builds ahead what a Poisson height of width x height will need (relief's
// kernels for it, and the FFT and DCT plans of that size), so that a front
// end can overlap it with reading the map. Errors are left for the height
// itself to meet and report.
// (Defined in plan_cache.cpp, beside the plans it fills.)
void prepare_height(ComputeContext& ctx, int width, int height);

}  // namespace relief::host
