// SPDX-License-Identifier: Apache-2.0
#pragma once
// The options of bake() (bake.h): plain data, no OpenImageIO.
#include "options.h"

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

}  // namespace relief
