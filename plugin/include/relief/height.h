#pragma once
// Integration: tangent-space normal map -> displacement (height) map.
#include <OpenImageIO/imagebuf.h>

#include "options.h"

namespace relief {

enum class HeightMethod { Rays };
enum class RayImpl { Reference };
enum class RayDirections { Exact };
enum class Boundary { Periodic, Clip };

struct HeightOptions {
    NormalDecoding normals;
    HeightMethod method = HeightMethod::Rays;
    // Radial ray integration (DESIGN.md §4.2).
    RayImpl impl = RayImpl::Reference;
    int rays = 32;         // J, number of ray directions (1..4096)
    float radius = 64.0f;  // R, ray length in texels
    float phase = 0.5f;    // angles 2*pi*(j + phase)/J, phase in [0, 1)
    RayDirections directions = RayDirections::Exact;
    // Periodic: the texture tiles, rays wrap. Clip: rays stop at the edge.
    Boundary boundary = Boundary::Periodic;
    Execution exec;
};

// Integrates the normal map's slopes into a displacement map: 1 float
// channel "Y", in texel units (1.0 = the width of one texel), bumps
// positive, zero mean. Metadata: relief:method, relief:parameters,
// relief:normal_convention, relief:height_unit ("texel").
// roi/nthreads/errors as in relief::slopes(); the roi is treated as the whole
// texture (the boundary applies at its edges).
OIIO::ImageBuf height(const OIIO::ImageBuf& normals, const HeightOptions& options = {},
                      OIIO::ROI roi = {}, int nthreads = 0);
bool height(OIIO::ImageBuf& dst, const OIIO::ImageBuf& normals,
            const HeightOptions& options = {}, OIIO::ROI roi = {}, int nthreads = 0);

// "impl=reference rays=32 radius=64 phase=0.5 directions=exact boundary=periodic"
std::string describe(const HeightOptions& options);

} // namespace relief
