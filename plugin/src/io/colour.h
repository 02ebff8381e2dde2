// SPDX-License-Identifier: Apache-2.0
#pragma once
// Colour decoding and encoding with OpenColorIO for baking.
#include <string>
#include <vector>

namespace relief::detail {

// Converts the first min(3, nch) channels of `px` (w*h texels of nch
// floats; alpha and further channels untouched) between the colour space
// `space` ("sRGB", or a name in $OCIO's config) and scene-linear. Without
// $OCIO, "sRGB" is the IEC 61966-2-1 curve (OCIO's ExponentWithLinear,
// gamma 2.4, offset 0.055) in a raw config. Throws std::runtime_error for
// a colour space the config does not know.
void to_linear(std::vector<float>& px, int nch, const std::string& space);
void from_linear(std::vector<float>& px, int nch, const std::string& space);

// "OCIO config <file>" or "built-in sRGB curve (no $OCIO)".
std::string colour_engine();

// The OpenColorIO library loaded, "2.1.2".
std::string ocio_version();

}  // namespace relief::detail
