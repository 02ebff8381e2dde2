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
};

// Integrates the slopes into `height_out` (width*height floats, texel units,
// zero mean).
void integrate_poisson(ComputeContext& ctx, const DeviceSlopes& slopes,
                       const PoissonParams& params, float* height_out);

// Gaussian sigma (texels) of the relief-balance filter for `highpass` texels.
double highpass_sigma(double highpass);

} // namespace relief::host
