// SPDX-License-Identifier: Apache-2.0
#pragma once
// The first stage of slopes() and height(): the normal map's texels read out
// of an ImageBuf and turned into the slope field on the device.
#include <OpenImageIO/imagebuf.h>

#include <memory>

#include "device/compute_context.h"
#include "relief/options.h"
#include "slopes/slope_stage.h"

namespace relief::detail {

struct DerivedSlopes {
    std::shared_ptr<host::ComputeContext> context;
    host::DeviceSlopes slopes;
    host::SlopeStats stats;
};

// `roi` must come from resolve_roi().
// Throws std::exception with a user-facing message on bad input or device
// trouble. Reports the chosen device, convention and counts through exec.
DerivedSlopes derive_slopes(const OIIO::ImageBuf& normals, OIIO::ROI roi, const NormalDecoding& decoding,
                            const Execution& exec);

// "opengl" / "directx"
const char* convention_name(host::GreenConvention c);

// Records what derive_slopes chose on an output image.
void tag_slope_metadata(OIIO::ImageSpec& spec, const host::SlopeStats& stats);

}  // namespace relief::detail
