// SPDX-License-Identifier: Apache-2.0
#pragma once
// Stage 4, baking the correction: texture resampled at u + c(u) on the
// device (kernels/bake.cl). Colour management happens before and after, in
// the plugin.
#include "device/compute_context.h"
#include "periodic_axes.h"

namespace relief::host {

enum class BakeFilter { Bilinear, Bicubic };

// src, dst: w*h*nch interleaved floats; offsets: 2*w*h floats (texture
// units). Along a periodic axis reads wrap around the texture, along the
// other they clamp.
void bake_gather(ComputeContext& ctx, const float* src, int w, int h, int nch, const float* offsets,
                 Periodic periodic, BakeFilter filter, float* dst);

}  // namespace relief::host
