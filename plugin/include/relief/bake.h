// SPDX-License-Identifier: Apache-2.0
#pragma once
// Baking a distortion correction into a texture: the texel at u takes the
// texture's value at u + c(u) (docs/design.md §4.5, "Application").
#include <OpenImageIO/imagebuf.h>

#include <string>

#include "bake_types.h"

#include "relief/export.h"

namespace relief {

// Resamples `texture` at u + offsets(u). `offsets`: 2 channels (du, dv) in
// texture units, the texture's size (relief::correct's output). The result
// has the texture's channels and metadata, and records the texture's file
// pixel type as relief:native_format (front ends write it back in that
// type unless told otherwise). roi/nthreads/errors as in relief::slopes().
RELIEF_API OIIO::ImageBuf bake(const OIIO::ImageBuf& texture, const OIIO::ImageBuf& offsets,
                               const BakeOptions& options = {}, OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool bake(OIIO::ImageBuf& dst, const OIIO::ImageBuf& texture, const OIIO::ImageBuf& offsets,
                     const BakeOptions& options = {}, OIIO::ROI roi = {}, int nthreads = 0);

}  // namespace relief
