// SPDX-License-Identifier: Apache-2.0
#pragma once
// Distortion correction: displacement (height) map -> texture-coordinate
// offset map (docs/design.md §4.5, after Zirr & Ritschel, "Distortion-Free
// Displacement Mapping", HPG 2019).
#include <OpenImageIO/imagebuf.h>

#include <string>
#include <vector>

#include "correct_types.h"

#include "relief/export.h"

namespace relief {

// Computes the offset map of a height map (channel 0): 2 float channels
// "du", "dv" in texture units (1 = the texture's width, height): the
// surface point at texture coordinate u shows the texture at u + c(u).
// Metadata: relief:method "correct", relief:boundary, relief:nodes,
// relief:scale, relief:parameters. roi/nthreads/errors as in relief::slopes().
RELIEF_API OIIO::ImageBuf correct(const OIIO::ImageBuf& height, const CorrectOptions& options = {},
                                  OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool correct(OIIO::ImageBuf& dst, const OIIO::ImageBuf& height, const CorrectOptions& options = {},
                        OIIO::ROI roi = {}, int nthreads = 0);

}  // namespace relief
