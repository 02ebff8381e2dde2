// SPDX-License-Identifier: Apache-2.0
#pragma once
// The options and report of height() (height.h) and height_udim() (udim.h):
// plain data, no OpenImageIO.
#include <string>

#include "options.h"
#include "relief/export.h"

namespace relief {

// Auto: Poisson with an automatic boundary, unless ray options are given.
enum class HeightMethod { Auto, Rays, Poisson };
// Fast: cost independent of the radius (docs/design.md §4.3), rational directions
// only. Reference: walks every ray (§4.2), either direction set.
enum class RayImpl { Fast, Reference };
// Rational: primitive integer steps (a, b) closest to the uniform angles.
// Exact: the uniform angles 2*pi*(j + phase)/J themselves.
enum class RayDirections { Rational, Exact };
// Periodic: the texture tiles (rays wrap; Poisson on a torus). Free: it does
// not (rays stop at the edge, "clip"; Poisson with zero normal slope at the
// edges, Neumann). Auto: each axis periodic when the surface continues
// across its wrap seam (the slopes correlate there as between neighbouring
// lines, or block heights step there no more than inside), else free; rays
// take periodic only when both axes do. The choice is reported.
enum class Boundary { Auto, Periodic, Free };
// A boundary for each axis: x (does the map wrap from its right edge to its
// left?) and y (from its bottom edge to its top?), for maps that tile along
// one axis only, such as trim sheets. One value sets both axes:
// `o.boundary = Boundary::Free`, and compared with one value, both axes
// must have it.
using Boundaries = PerAxis<Boundary>;

// How height_udim() (relief/udim.h) integrates a UDIM set. Joint: the set is
// one surface, laid out by its tile numbers on one canvas (missing tiles
// weighted 0) and solved once. Each: every tile alone. Auto: tiles whose
// shared edge passes the wrap-seam slope test are joined, the others cut.
// height() of one map ignores it.
enum class UdimMode { Auto, Joint, Each };

// What height() chose and how well its result reproduces the normals it
// came from (the round trip). Filled when HeightOptions::report is set, at
// the cost of one more pass over the map.
struct HeightReport {
    std::string method;             // "poisson" or "rays"
    std::string normal_convention;  // "opengl" or "directx", as decoded
    // "periodic", "free" (poisson) or "clip" (rays); x's and y's, comma
    // separated, where they differ ("periodic,free": x periodic, y free)
    std::string boundary;
    int width = 0, height = 0;
    // The angle (degrees) between the decoded input normals (after the
    // grazing clamp) and the normals re-derived from the height with
    // normals()'s central differences under the same boundary: mean, 95th
    // percentile (nearest rank) and maximum over the texels.
    double angular_error_mean = 0.0, angular_error_p95 = 0.0, angular_error_max = 0.0;
    // sum |g - grad h|^2 / sum |g|^2 with the same differences (0 for flat
    // input): for least squares the part of the slopes no height can
    // reproduce (curl), for rays also what the rays' high-pass removed.
    double residual_share = 0.0;
    double seconds = 0.0;  // the whole height() call

    RELIEF_API std::string to_json() const;  // the "height" object of --report
};

struct HeightOptions {
    NormalDecoding normals;
    HeightMethod method = HeightMethod::Auto;
    // Least squares takes one per axis; rays one for both (periodic or clip).
    Boundaries boundary = Boundary::Auto;
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
    // Weighted solves are the discrete least squares of docs/design.md §4.4 by
    // conjugate gradients; an all-ones mask changes nothing.
    const OIIO::ImageBuf* mask = nullptr;
    bool mask_alpha = false;
    HeightReport* report = nullptr;  // filled when set (not owned)
    UdimMode udim = UdimMode::Auto;  // height_udim() only
    Execution exec;
};

}  // namespace relief
