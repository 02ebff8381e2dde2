// SPDX-License-Identifier: Apache-2.0
#pragma once
// The options of preview() (preview.h): plain data, no OpenImageIO.
#include <string>

#include "height_types.h"
#include "options.h"

namespace relief {

struct PreviewOptions {
    NormalDecoding normals;  // how to decode the normal map (as --height did)
    // The key light: azimuth counter-clockwise from the image's +x (right)
    // edge direction, so 90 is from the top of the image; elevation above
    // the surface. Degrees.
    float azimuth = 135.0f, elevation = 45.0f;
    // Diffuse image-based lighting from this lat-long environment's 9
    // spherical-harmonic irradiance coefficients (rows: zenith to nadir;
    // columns: azimuth as the light's). Integer files are decoded as sRGB.
    // Empty: a procedural sky.
    std::string env;
    // Of the height's differences (as normals()): Auto takes the height's
    // relief:parameters, else the seam test. Per axis.
    Boundaries boundary = Boundary::Auto;
    Execution exec;
};

}  // namespace relief
