// SPDX-License-Identifier: Apache-2.0
#pragma once
// A labelled preview sheet of a height against the normal map it came from:
// both lit under the same light, an emboss view, the angular error and the
// height with colour bars.
#include <OpenImageIO/imagebuf.h>

#include <string>

#include "preview_types.h"
#include "relief/export.h"
#include "relief/height.h"

namespace relief {

// An 8-bit RGB sheet (sRGB) of five captioned panels, each at the map's
// resolution clamped to 344..1024 texels wide: (a) the input normals lit
// and (b) the height's re-derived normals lit, by the key light plus the
// environment's diffuse light; (c) emboss: the height one texel toward the
// light minus the height; (d) the angular error between (a) and (b)'s
// normals (degrees, heat map and colour bar); (e) the height (texels,
// colour bar). A sixth cell states the light, the convention and the
// round-trip numbers. (Panels of maps over about 6 times taller than wide
// are narrower: they are kept under 2048 texels tall.) `normals` and `height` must have the same size.
// Metadata: relief:native_format "uint8" (the command line writes 8 bits).
RELIEF_API OIIO::ImageBuf preview(const OIIO::ImageBuf& normals, const OIIO::ImageBuf& height,
                                  const PreviewOptions& options = {});
RELIEF_API bool preview(OIIO::ImageBuf& dst, const OIIO::ImageBuf& normals, const OIIO::ImageBuf& height,
                        const PreviewOptions& options = {});

// The 9 spherical-harmonic coefficients (RGB each; order L00, L1-1, L10,
// L11, L2-2, L2-1, L20, L21, L22) of a lat-long environment's radiance, and
// the irradiance they give a surface of unit normal n (image frame: x
// right, y down, z up), after Ramamoorthi and Hanrahan (2001), as in GPU
// Gems ch. 19. Exposed for tests.
struct SphericalHarmonics {
    float c[9][3] = {};
};
RELIEF_API SphericalHarmonics environment_harmonics(const OIIO::ImageBuf& latlong);
RELIEF_API SphericalHarmonics sky_harmonics();
RELIEF_API void irradiance(const SphericalHarmonics& sh, const float n[3], float rgb[3]);

}  // namespace relief
