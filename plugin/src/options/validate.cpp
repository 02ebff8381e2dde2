// SPDX-License-Identifier: Apache-2.0
// validate(): every rule on an operation's options, written once. The
// operations call it first; the table calls it once a call's modifiers are
// parsed, so the command line, the C ABI and Python word a rule as the C++
// API does. The host below checks only its own invariants.
#include "relief/validate.h"

#include <cmath>
#include <string>

#include "option_limits.h"

namespace relief {

namespace {

using detail::range_problem;
namespace limits = detail::limits;

// The first non-empty problem.
std::string first(std::initializer_list<std::string> problems)
{
    for (const std::string& p : problems)
        if (!p.empty())
            return p;
    return "";
}

// An enum field set in C++ to a value it does not name (a cast, memory
// gone bad): its number and the words it takes.
template <class E>
std::string choice_problem(const char* name, E value, int count, const char* choices)
{
    const int v = int(value);
    return v >= 0 && v < count ? "" : detail::not_one_of(name, std::to_string(v), choices);
}

std::string decoding_problem(const NormalDecoding& d)
{
    return first({choice_problem("normal", d.convention, 3, "auto|opengl|directx"),
                  choice_problem("range", d.float_encoding, 2, "signed|unsigned"),
                  range_problem(limits::max_angle, d.max_angle)});
}

}  // namespace

std::string validate(const SlopeOptions& o)
{
    return decoding_problem(o.normals);
}

std::string validate(const HeightOptions& o)
{
    if (std::string p =
            first({decoding_problem(o.normals), choice_problem("method", o.method, 3, "auto|rays|poisson"),
                   choice_problem("boundary", o.boundary.x, 3, "auto|periodic|free"),
                   choice_problem("boundary", o.boundary.y, 3, "auto|periodic|free"),
                   choice_problem("impl", o.impl, 2, "fast|reference"),
                   choice_problem("directions", o.directions, 2, "rational|exact"),
                   choice_problem("udim", o.udim, 3, "auto|joint|each"),
                   range_problem(limits::highpass, o.highpass), range_problem(limits::rays, o.rays),
                   range_problem(limits::radius, o.radius), range_problem(limits::phase, o.phase)});
        !p.empty())
        return p;
    const bool rays = o.method == HeightMethod::Rays;
    const bool masked = o.mask || o.mask_alpha;
    if (rays && o.impl == RayImpl::Fast && o.directions == RayDirections::Exact)
        return "impl=fast needs directions=rational (or use impl=reference)";
    if (rays && o.highpass > 0.0f)
        return "highpass applies to method=poisson, not to rays";
    if (rays && masked)
        return "a mask applies to method=poisson, not to rays";
    if (rays && o.boundary.x != o.boundary.y)
        return "rays take one boundary for both axes (periodic, clip or auto); a boundary per axis "
               "needs method=poisson";
    if (o.mask && o.mask_alpha)
        return "give a mask image or mask_alpha, not both";
    if (masked && o.highpass > 0.0f)
        return "highpass cannot be combined with a mask yet";
    if (o.udim == UdimMode::Joint && o.mask)
        return "udim=joint takes mask=alpha (each tile's alpha), not a mask image (one tile's weights)";
    return "";
}

std::string validate(const CorrectOptions& o)
{
    if (std::string p = first(
            {choice_problem("nodes", o.nodes, 2, "corner|center"),
             choice_problem("boundary", o.boundary.x, 3, "auto|periodic|fixed"),
             choice_problem("boundary", o.boundary.y, 3, "auto|periodic|fixed"),
             choice_problem("search", o.search, 3, "brent|golden|ternary"),
             range_problem(limits::displacement_scale, o.scale), range_problem(limits::theta, o.theta),
             range_problem(limits::iterations, o.iterations), range_problem(limits::tolerance, o.tolerance),
             range_problem(limits::levels, o.levels), range_problem(limits::threshold, o.threshold),
             range_problem(limits::relax, o.relax), range_problem(limits::polish, o.polish)});
        !p.empty())
        return p;
    if (o.max_iterations < 1)
        return "max_iterations must be >= 1";
    if (std::string p = first({range_problem(limits::fix_width, o.fix_width),
                               o.fix_width > 0.0f ? range_problem(limits::fix_height, o.fix_height) : ""});
        !p.empty())
        return p;
    if (o.fix_mask && o.fix_width > 0.0f)
        return "give a fixation mask or a height tent, not both";
    return "";
}

std::string validate(const BakeOptions& o)
{
    // (kind=height is refused by bake(), which may find a height map by itself)
    return first({choice_problem("filter", o.filter, 2, "bilinear|bicubic"),
                  choice_problem("colorspace", o.colorspace, 4, "auto|sRGB|linear|raw"),
                  choice_problem("kind", o.kind, 5, "auto|color|normal|data|height"),
                  choice_problem("wrap", o.wrap, 3, "auto|periodic|clamp")});
}

std::string validate(const NormalsOptions& o)
{
    // A height has no green convention to detect: auto is not one of them.
    if (o.convention == NormalConvention::Auto)
        return detail::not_one_of("normal", "auto", "opengl|directx");
    return first({choice_problem("normal", o.convention, 3, "opengl|directx"),
                  choice_problem("boundary", o.boundary.x, 3, "auto|periodic|free"),
                  choice_problem("boundary", o.boundary.y, 3, "auto|periodic|free"),
                  range_problem(limits::surface_scale, o.scale)});
}

std::string validate(const TessellationOptions& o)
{
    return first({range_problem(limits::patch, o.patch), range_problem(limits::error, o.error),
                  range_problem(limits::surface_scale, o.scale)});
}

std::string validate(const MeshOptions& o)
{
    return first({validate(o.tessellation), mesh_path_problem(o.out)});
}

std::string validate(const PreviewOptions& o)
{
    if (std::string p = first({decoding_problem(o.normals),
                               choice_problem("boundary", o.boundary.x, 3, "auto|periodic|free"),
                               choice_problem("boundary", o.boundary.y, 3, "auto|periodic|free")});
        !p.empty())
        return p;
    if (!detail::within(limits::light_azimuth, o.azimuth) ||
        !detail::within(limits::light_elevation, o.elevation))
        return "light=" + detail::number_text(o.azimuth) + "," + detail::number_text(o.elevation) +
               " needs AZ in " + detail::range_text(limits::light_azimuth) + " and EL in " +
               detail::range_text(limits::light_elevation);
    return "";
}

}  // namespace relief
