// SPDX-License-Identifier: Apache-2.0
#pragma once
// Integration: tangent-space normal map -> displacement (height) map.
#include <OpenImageIO/imagebuf.h>

#include <string>

#include "height_types.h"

#include "relief/export.h"

namespace relief {

// Integrates the normal map's slopes into a displacement map: 1 float
// channel "Y", in texel units (1.0 = the width of one texel), bumps
// positive, zero mean. Metadata: relief:method, relief:parameters,
// relief:normal_convention, relief:height_unit ("texel").
// roi/nthreads/errors as in relief::slopes(); the roi is treated as the whole
// texture (the boundary applies at its edges).
RELIEF_API OIIO::ImageBuf height(const OIIO::ImageBuf& normals, const HeightOptions& options = {},
                                 OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool height(OIIO::ImageBuf& dst, const OIIO::ImageBuf& normals, const HeightOptions& options = {},
                       OIIO::ROI roi = {}, int nthreads = 0);

// "method=rays impl=fast rays=32 radius=64 phase=0.5 directions=rational boundary=periodic"
// or "method=poisson boundary=free highpass=0"; the values as given (auto
// stays auto; the result's relief:parameters records what was chosen).
RELIEF_API std::string describe(const HeightOptions& options);

}  // namespace relief
