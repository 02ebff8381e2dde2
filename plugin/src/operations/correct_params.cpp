// SPDX-License-Identifier: Apache-2.0
#include "correct_params.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "results.h"
#include "seams.h"

namespace relief::detail {

namespace {

// "periodic", "fixed", or x's and y's ("periodic,fixed"): the word of the
// boundary modifier that reproduces the choice.
std::string boundary_name(host::Periodic p)
{
    const auto word = [](bool periodic) { return periodic ? "periodic" : "fixed"; };
    return p.x == p.y ? word(p.x) : std::string(word(p.x)) + "," + word(p.y);
}

const char* search_name(CorrectSearch s)
{
    return s == CorrectSearch::Ternary ? "ternary" : s == CorrectSearch::Golden ? "golden" : "brent";
}

const char* hats_name(CorrectHats h)
{
    return h == CorrectHats::Off ? "off" : h == CorrectHats::Always ? "always" : "auto";
}

const char* global_name(CorrectGlobal g)
{
    return g == CorrectGlobal::Off ? "off" : g == CorrectGlobal::Always ? "always" : "auto";
}

// The fixation weights of `options` (empty: none).
std::vector<float> fixation(const std::vector<float>& heights, int w, int h, const CorrectOptions& options)
{
    std::vector<float> fix;
    if (options.fix_mask) {
        const OIIO::ImageBuf& m = *options.fix_mask;
        if (m.spec().width != w || m.spec().height != h)
            throw std::runtime_error("the fixation mask is " + std::to_string(m.spec().width) + "x" +
                                     std::to_string(m.spec().height) + ", the height map " +
                                     std::to_string(w) + "x" + std::to_string(h));
        fix = channel0(m, m.roi(), "fixation mask");
        for (float v : fix)
            if (!(v >= 0.0f) || !std::isfinite(v))
                throw std::runtime_error("fixation weights must be finite and >= 0");
    } else if (options.fix_width > 0.0f) {
        fix.resize(heights.size());
        for (std::size_t i = 0; i < fix.size(); ++i)
            fix[i] = std::max(0.0f, 1.0f - std::abs(heights[i] - options.fix_height) / options.fix_width);
    }
    return fix;
}

}  // namespace

CorrectCall correct_call(const OIIO::ImageBuf& height, const std::vector<float>& heights, int w, int h,
                         const CorrectOptions& options)
{
    CorrectCall call;
    host::CorrectParams& p = call.base;
    p.scale = options.scale;
    if (p.scale == 0.0) {
        if (height.spec().get_string_attribute("relief:height_unit") != "texel")
            throw std::runtime_error(
                "give the displacement scale (scale=S: world height = S x stored value, the "
                "texture's width = 1); only relief's own height maps (in texels) imply it");
        p.scale = 1.0 / w;
    }
    p.theta = options.theta;
    p.corner_nodes = options.nodes == CorrectNodes::Corner;
    const bool any_auto =
        options.boundary.x == CorrectBoundary::Auto || options.boundary.y == CorrectBoundary::Auto;
    const SeamTest seams = any_auto ? seam_test(heights, w, h) : SeamTest{};
    const auto axis = [](CorrectBoundary b, bool seam_periodic) {
        return b == CorrectBoundary::Auto ? seam_periodic : b == CorrectBoundary::Periodic;
    };
    p.periodic = host::Periodic(axis(options.boundary.x, seams.periodic.x),
                                axis(options.boundary.y, seams.periodic.y));
    call.boundary = boundary_name(p.periodic);
    if (any_auto)
        say(options.exec, Severity::Notice,
            "correct: boundary " + call.boundary + " (" + seams.numbers() + ")");
    call.fix = fixation(heights, w, h, options);
    p.iterations = options.iterations;
    p.tolerance = options.tolerance;
    p.max_iterations = options.max_iterations;
    p.levels = options.levels;
    p.threshold = options.threshold;
    p.skip_tiles = options.skip_tiles;
    p.search = options.search;
    p.relax = options.relax;
    p.polish = options.polish;
    p.hats = options.hats;
    p.global = options.global;
    return call;
}

CorrectReport correct_report(const host::CorrectReport& done, const CorrectCall& call, int w, int h)
{
    CorrectReport rep;
    rep.width = w;
    rep.height = h;
    rep.skipped = done.skipped;
    rep.boundary = call.boundary;
    rep.nodes = call.base.corner_nodes ? "corner" : "center";
    rep.scale = call.base.scale;
    rep.energy_before = done.energy_before;
    rep.energy_after = done.energy_after;
    rep.polish = done.polish;
    rep.iterations = done.total_iterations();
    for (const auto& l : done.levels)
        rep.levels.push_back({l.width, l.height, l.iterations, l.energy_start, l.energy_end, l.converged,
                              l.tile_phases ? double(l.tile_phases_run) / l.tile_phases : 1.0, l.seconds,
                              l.start_factor, l.hat_sweeps, l.global_steps});
    rep.anisotropy_before = done.anisotropy_before;
    rep.anisotropy_after = done.anisotropy_after;
    rep.area_before = done.area_before;
    rep.area_after = done.area_after;
    return rep;
}

std::string correct_parameters(const CorrectCall& call, const CorrectOptions& options)
{
    const host::CorrectParams& p = call.base;
    std::ostringstream par;
    par << "scale=" << p.scale << " theta=" << p.theta << " nodes=" << (p.corner_nodes ? "corner" : "center")
        << " boundary=" << call.boundary << " tolerance=" << p.tolerance
        << " iterations=" << (p.iterations ? std::to_string(p.iterations) : "auto")
        << " levels=" << (p.levels ? std::to_string(p.levels) : "auto") << " threshold=" << p.threshold
        << " search=" << search_name(options.search) << " relax=" << p.relax
        << " hats=" << hats_name(options.hats) << " global=" << global_name(options.global)
        << " polish=" << (p.corner_nodes ? p.polish : 0);
    return par.str();
}

}  // namespace relief::detail
