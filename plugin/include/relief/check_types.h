// SPDX-License-Identifier: Apache-2.0
#pragma once
// The options of normals() and tessellation() (check.h): plain data, no
// OpenImageIO.
#include "height_types.h"
#include "options.h"

namespace relief {

struct NormalsOptions {
    // The green convention to store: OpenGL (G = -n_y, Y+) or DirectX
    // (G = +n_y, Y-). Auto is not accepted here: a file has one convention.
    NormalConvention convention = NormalConvention::OpenGL;
    float scale = 1.0f;  // the height in texels is multiplied by this first
    // Per axis, periodic: differences wrap; free: one-sided at the edges.
    // Auto: the boundary the height was integrated with (relief:parameters),
    // else each axis periodic when the height is continuous across its wrap
    // seam.
    Boundaries boundary = Boundary::Auto;
    Execution exec;
};

struct TessellationOptions {
    int patch = 32;      // P: patches of P x P texels (the last row/column may be narrower)
    float error = 0.5f;  // E: the largest allowed deviation, in the units of scale * height
    float scale = 1.0f;  // S: the surface is S * height (texels)
    Execution exec;
};

}  // namespace relief
