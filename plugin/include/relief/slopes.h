// SPDX-License-Identifier: Apache-2.0
#pragma once
// DDM derivation: tangent-space normal map -> depth-difference map.
#include <OpenImageIO/imagebuf.h>

#include "slopes_types.h"

#include "relief/export.h"

namespace relief {

// Derives the slope field (docs/design.md §4.1) of the normal map `normals`
// (2, 3 or 4 channels; a 4th channel is ignored; 8/16-bit UNORM, half or
// float). The result has 2 float channels "gx", "gy": height change per texel
// step along x (column, right) and y (row, down), in texel units. Metadata:
// relief:normal_convention, relief:curl_opengl/directx (auto only),
// relief:invalid_normals, relief:clamped_normals.
//
// roi: the region of `normals` to use (default: all of it); the result
// covers that region. nthreads: accepted for ImageBufAlgo compatibility; the
// work runs on the OpenCL device, whose driver decides its parallelism.
// On failure the returned image has_error() and geterror() says why.
RELIEF_API OIIO::ImageBuf slopes(const OIIO::ImageBuf& normals, const SlopeOptions& options = {},
                                 OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool slopes(OIIO::ImageBuf& dst, const OIIO::ImageBuf& normals, const SlopeOptions& options = {},
                       OIIO::ROI roi = {}, int nthreads = 0);

}  // namespace relief
