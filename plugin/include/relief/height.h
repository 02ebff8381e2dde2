#pragma once
// Integration: tangent-space normal map -> displacement (height) map.
#include <OpenImageIO/imagebuf.h>

#include "options.h"

#include "relief/export.h"

namespace relief {

// Auto: Poisson with an automatic boundary, unless ray options are given.
enum class HeightMethod { Auto, Rays, Poisson };
// Fast: cost independent of the radius (DESIGN.md §4.3), rational directions
// only. Reference: walks every ray (§4.2), either direction set.
enum class RayImpl { Fast, Reference };
// Rational: primitive integer steps (a, b) closest to the uniform angles.
// Exact: the uniform angles 2*pi*(j + phase)/J themselves.
enum class RayDirections { Rational, Exact };
// Periodic: the texture tiles (rays wrap; Poisson on a torus). Free: it does
// not (rays stop at the edge, "clip"; Poisson with zero normal slope at the
// edges, Neumann). Auto: periodic when the slopes are as continuous across
// the wrap seams as inside the texture, else free; the choice is reported.
enum class Boundary { Auto, Periodic, Free };

struct HeightOptions {
    NormalDecoding normals;
    HeightMethod method = HeightMethod::Auto;
    Boundary boundary = Boundary::Auto;
    // Radial ray integration (method=rays).
    RayImpl impl = RayImpl::Fast;
    int rays = 32;         // J, number of ray directions (1..4096)
    float radius = 64.0f;  // R, ray length in texels
    float phase = 0.5f;    // angles 2*pi*(j + phase)/J, phase in [0, 1)
    RayDirections directions = RayDirections::Rational;
    // Skip tiles whose rays cross only zero slopes (flat parts of an atlas);
    // the result is bit-identical either way.
    bool skip_flat = true;
    // Least squares (method=poisson): relief balance, removes structure
    // larger than this many texels (0 = off).
    float highpass = 0.0f;
    // Per-texel confidence weights for least squares, in [0, 1] (0 =
    // excluded: the texel's slopes are ignored and its height filled
    // smoothly; Knald-style): channel 0 of `mask` (same size as the
    // normals' roi; not owned), or the normal map's alpha with mask_alpha.
    // Weighted solves are the discrete least squares of DESIGN §4.4 by
    // conjugate gradients; an all-ones mask changes nothing.
    const OIIO::ImageBuf* mask = nullptr;
    bool mask_alpha = false;
    Execution exec;
};

// Integrates the normal map's slopes into a displacement map: 1 float
// channel "Y", in texel units (1.0 = the width of one texel), bumps
// positive, zero mean. Metadata: relief:method, relief:parameters,
// relief:normal_convention, relief:height_unit ("texel").
// roi/nthreads/errors as in relief::slopes(); the roi is treated as the whole
// texture (the boundary applies at its edges).
RELIEF_API OIIO::ImageBuf height(const OIIO::ImageBuf& normals, const HeightOptions& options = {},
                      OIIO::ROI roi = {}, int nthreads = 0);
RELIEF_API bool height(OIIO::ImageBuf& dst, const OIIO::ImageBuf& normals,
            const HeightOptions& options = {}, OIIO::ROI roi = {}, int nthreads = 0);

// "method=rays impl=fast rays=32 radius=64 phase=0.5 directions=rational boundary=periodic"
// or "method=poisson boundary=free highpass=0"; the values as given (auto
// stays auto; the result's relief:parameters records what was chosen).
RELIEF_API std::string describe(const HeightOptions& options);

} // namespace relief
