// SPDX-License-Identifier: Apache-2.0
#pragma once
// Baking a distortion correction into a texture: the texel at u takes the
// texture's value at u + c(u) (docs/design.md §4.5, "Application").
#include <OpenImageIO/imagebuf.h>

#include <string>

#include "options.h"

#include "relief/export.h"

namespace relief {

enum class BakeFilter { Bilinear, Bicubic };  // bicubic: Catmull-Rom
// How colour is decoded to linear light before filtering and encoded after:
// Auto: the file's declared colour space (oiio:ColorSpace), 8-bit PNG/JPEG
// as sRGB, float files as linear; SRGB, Linear; Raw: no conversion (data).
enum class BakeColorspace { Auto, SRGB, Linear, Raw };
// What the texture holds. Auto: a normal map when its name says so or its
// texels are unit vectors in [0,1] encoding with +z up; a height map when
// it is relief's own or a one-channel map named height/disp/bump; else
// colour (or data with colorspace=raw). Normal maps bake as data and are
// renormalised; height (displacement) maps are refused: their texels must
// stay where they are.
enum class BakeKind { Auto, Color, Normal, Data, Height };
// Periodic: reads wrap around (tiling textures); Clamp: they stop at the
// edge; Auto: what the offset map's relief:boundary says, per axis
// (periodic, else clamp; "periodic,fixed": wrap along x only).
enum class BakeWrap { Auto, Periodic, Clamp };

struct BakeOptions {
    BakeFilter filter = BakeFilter::Bilinear;
    BakeColorspace colorspace = BakeColorspace::Auto;
    BakeKind kind = BakeKind::Auto;
    BakeWrap wrap = BakeWrap::Auto;
    Execution exec;
};

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
