// SPDX-License-Identifier: Apache-2.0
#pragma once
// Checking a result: a height map's own normal map (the inverse of the DDM)
// and the tessellation levels a renderer needs for it. The round trip of
// height() is in HeightReport (height.h); the preview sheet in preview.h,
// the displaced mesh in mesh.h.
#include <OpenImageIO/imagebuf.h>

#include "check_types.h"
#include "relief/export.h"
#include "relief/height.h"

namespace relief {

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
