// SPDX-License-Identifier: Apache-2.0
#pragma once
// Checking a result: a height map's own normal map (the inverse of the DDM)
// and the tessellation levels a renderer needs for it. The round trip of
// height() is in HeightReport (height.h); the preview sheet in preview.h,
// the displaced mesh in mesh.h.
#include <OpenImageIO/imagebuf.h>

#include "options.h"
#include "relief/export.h"
#include "relief/height.h"

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

// Height (channel 0, texel units) -> 3-channel unit normal map "R", "G",
// "B": slopes by central differences (h[x+1] - h[x-1])/2 (one-sided at the
// edges of a free map), n = normalize(-s gx, -s gy, 1) in the image frame,
// G stored per the convention. Float pixels in [-1, 1]; write_image() stores
// (v + 1)/2 in integer files. Metadata: relief:method "normals",
// relief:normal_convention.
RELIEF_API OIIO::ImageBuf normals(const OIIO::ImageBuf& height, const NormalsOptions& options = {},
                                  OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool normals(OIIO::ImageBuf& dst, const OIIO::ImageBuf& height, const NormalsOptions& options = {},
                        OIIO::ROI roi = {}, int nthreads = 0);

struct TessellationOptions {
    int patch = 32;      // P: patches of P x P texels (the last row/column may be narrower)
    float error = 0.5f;  // E: the largest allowed deviation, in the units of scale * height
    float scale = 1.0f;  // S: the surface is S * height (texels)
    Execution exec;
};

// Height -> 1-channel level map "L" of ceil(W/P) x ceil(H/P): per patch the
// lowest level L in 1..64 such that splitting the patch into L x L quads
// (two triangles each, cut along the diagonal pointing away from the patch
// centre) with vertex heights sampled bilinearly from S*h (texel (i, j) at
// (i + 0.5, j + 0.5), clamped at the edges) keeps the surface within E of
// S*h at every texel centre of the patch; 64 where no level does (counted
// and reported). Flat patches (all texels equal) are level 1. Integer files store the level
// itself as the code. Metadata: relief:method "tessellation",
// relief:patch, relief:error, relief:scale.
RELIEF_API OIIO::ImageBuf tessellation(const OIIO::ImageBuf& height, const TessellationOptions& options = {},
                                       OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool tessellation(OIIO::ImageBuf& dst, const OIIO::ImageBuf& height,
                             const TessellationOptions& options = {}, OIIO::ROI roi = {}, int nthreads = 0);

}  // namespace relief
