#pragma once
// Stage 2, least-squares (Poisson) integration (DESIGN.md §4.4):
// slopes -> height, by Frankot–Chellappa projection with FFTs (periodic) or
// DCTs (free) on the device.
#include "compute_context.h"
#include "slope_stage.h"

namespace relief::host {

enum class PoissonBoundary { Periodic, Free };

struct PoissonParams {
    PoissonBoundary boundary = PoissonBoundary::Periodic;
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
void integrate_poisson(ComputeContext& ctx, const DeviceSlopes& slopes,
                       const PoissonParams& params, float* height_out,
                       PoissonReport* report = nullptr);

// Gaussian sigma (texels) of the relief-balance filter for `highpass` texels.
double highpass_sigma(double highpass);

} // namespace relief::host
