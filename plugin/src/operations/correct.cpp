// SPDX-License-Identifier: Apache-2.0
// relief::correct — the distortion-correction family (height -> offsets).
#include "relief/validate.h"
#include "relief/correct.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "device/compute_context.h"
#include "correct/correct_stage.h"
#include "results.h"
#include "seams.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

namespace {

DistortionSummary summary(const host::DistortionStats& s)
{
    return {s.mean, s.p95, s.max};
}

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

// What the iteration limit counted besides the nodes' iterations.
std::string counted_as_iterations(const CorrectLevelReport& l)
{
    const std::string what = l.hat_sweeps && l.global_steps ? "each hat sweep and global step"
                             : l.hat_sweeps                 ? "each hat sweep"
                             : l.global_steps               ? "each global step"
                                                            : "";
    return what.empty() ? what : " (" + what + " counted as the iterations it costs)";
}

const char* global_name(CorrectGlobal g)
{
    return g == CorrectGlobal::Off ? "off" : g == CorrectGlobal::Always ? "always" : "auto";
}

}  // namespace

std::string CorrectReport::to_json() const
{
    using Json = nlohmann::ordered_json;
    const auto stats = [](const DistortionSummary& d) {
        return Json{{"mean", d.mean}, {"p95", d.p95}, {"max", d.max}};
    };
    Json j;
    j["width"] = width;
    j["height"] = height;
    j["skipped"] = skipped;
    j["boundary"] = boundary;
    j["nodes"] = nodes;
    j["scale"] = scale;
    j["energy_before"] = energy_before;
    j["energy_after"] = energy_after;
    j["iterations"] = iterations;
    j["levels"] = Json::array();
    for (const auto& l : levels)
        j["levels"].push_back({{"width", l.width},
                               {"height", l.height},
                               {"iterations", l.iterations},
                               {"energy_start", l.energy_start},
                               {"energy_end", l.energy_end},
                               {"converged", l.converged},
                               {"tiles_run", l.tiles_run},
                               {"seconds", l.seconds},
                               {"start_factor", l.start_factor},
                               {"hat_sweeps", l.hat_sweeps},
                               {"global_steps", l.global_steps}});
    j["polish"] = {{"flipped", polish.flipped},
                   {"repairs", polish.repairs},
                   {"flipped_left", polish.flipped_left},
                   {"iterations", polish.iterations},
                   {"energy_start", polish.energy_start},
                   {"energy_end", polish.energy_end},
                   {"seconds", polish.seconds}};
    j["anisotropy"] = {{"before", stats(anisotropy_before)}, {"after", stats(anisotropy_after)}};
    j["area_ratio"] = {{"before", stats(area_before)}, {"after", stats(area_after)}};
    j["seconds"] = seconds;
    return j.dump(2) + "\n";
}

ImageBuf correct(const ImageBuf& height, const CorrectOptions& options, ROI roi, int nthreads)
{
    return detail::first_form([&](ImageBuf& dst) { correct(dst, height, options, roi, nthreads); });
}

bool correct(ImageBuf& dst, const ImageBuf& height, const CorrectOptions& options, ROI roi, int /*nthreads*/)
{
    try {
        const detail::OperationScope scope(options.exec);
        const auto t0 = std::chrono::steady_clock::now();
        detail::require_valid(options);
        roi = detail::resolve_roi(height, roi);
        const int w = roi.width(), h = roi.height();
        const std::vector<float> heights = detail::height_channel(height, roi, options.exec, "correct");

        host::CorrectParams p;
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
        const detail::SeamTest seams = any_auto ? detail::seam_test(heights, w, h) : detail::SeamTest{};
        const auto axis = [](CorrectBoundary b, bool seam_periodic) {
            return b == CorrectBoundary::Auto ? seam_periodic : b == CorrectBoundary::Periodic;
        };
        p.periodic = host::Periodic(axis(options.boundary.x, seams.periodic.x),
                                    axis(options.boundary.y, seams.periodic.y));
        const std::string chosen = boundary_name(p.periodic);
        if (any_auto)
            detail::say(options.exec, Severity::Notice,
                        "correct: boundary " + chosen + " (" + seams.numbers() + ")");
        std::vector<float> fix;
        if (options.fix_mask) {
            const ImageBuf& m = *options.fix_mask;
            if (m.spec().width != w || m.spec().height != h)
                throw std::runtime_error("the fixation mask is " + std::to_string(m.spec().width) + "x" +
                                         std::to_string(m.spec().height) + ", the height map " +
                                         std::to_string(w) + "x" + std::to_string(h));
            fix = detail::channel0(m, m.roi(), "fixation mask");
            for (float v : fix)
                if (!(v >= 0.0f) || !std::isfinite(v))
                    throw std::runtime_error("fixation weights must be finite and >= 0");
        } else if (options.fix_width > 0.0f) {
            fix.resize(heights.size());
            for (std::size_t i = 0; i < fix.size(); ++i)
                fix[i] = std::max(0.0f, 1.0f - std::abs(heights[i] - options.fix_height) / options.fix_width);
        }
        p.fix_weights = fix.empty() ? nullptr : fix.data();
        p.iterations = options.iterations;
        p.tolerance = options.tolerance;
        p.max_iterations = options.max_iterations;
        p.levels = options.levels;
        p.threshold = options.threshold;
        p.skip_tiles = options.skip_tiles;
        p.search = options.search == CorrectSearch::Ternary  ? host::CorrectParams::Search::Ternary
                   : options.search == CorrectSearch::Golden ? host::CorrectParams::Search::Golden
                                                             : host::CorrectParams::Search::Brent;
        p.relax = options.relax;
        p.polish = options.polish;
        p.hats = options.hats == CorrectHats::Off      ? host::CorrectParams::Hats::Off
                 : options.hats == CorrectHats::Always ? host::CorrectParams::Hats::Always
                                                       : host::CorrectParams::Hats::Auto;
        p.global = options.global == CorrectGlobal::Off      ? host::CorrectParams::Global::Off
                   : options.global == CorrectGlobal::Always ? host::CorrectParams::Global::Always
                                                             : host::CorrectParams::Global::Auto;

        auto ctx = host::ComputeContext::acquire(options.exec.device);
        detail::say(options.exec, Severity::Info, "device: " + ctx->device().describe());
        std::vector<float> offsets(2 * std::size_t(w) * h);
        host::CorrectReport hr;
        host::correct_distortion(*ctx, heights.data(), w, h, p, offsets.data(), &hr,
                                 options.exec.on_progress);

        CorrectReport rep;
        rep.width = w;
        rep.height = h;
        rep.skipped = hr.skipped;
        rep.boundary = chosen;
        rep.nodes = p.corner_nodes ? "corner" : "center";
        rep.scale = p.scale;
        rep.energy_before = hr.energy_before;
        rep.energy_after = hr.energy_after;
        rep.polish = {hr.polish.flipped,      hr.polish.flipped_left, hr.polish.repairs, hr.polish.iterations,
                      hr.polish.energy_start, hr.polish.energy_end,   hr.polish.seconds};
        rep.iterations = hr.total_iterations();
        for (const auto& l : hr.levels)
            rep.levels.push_back({l.width, l.height, l.iterations, l.energy_start, l.energy_end, l.converged,
                                  l.tile_phases ? double(l.tile_phases_run) / l.tile_phases : 1.0, l.seconds,
                                  l.start_factor, l.hat_sweeps, l.global_steps});
        rep.anisotropy_before = summary(hr.anisotropy_before);
        rep.anisotropy_after = summary(hr.anisotropy_after);
        rep.area_before = summary(hr.area_before);
        rep.area_after = summary(hr.area_after);
        rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

        const auto& ex = options.exec;
        auto f = [](double v) { return detail::format_double("%.4g", v); };
        if (rep.skipped) {
            detail::say(ex, Severity::Notice,
                        "correct: nothing to correct (max anisotropy " + f(rep.anisotropy_before.max) +
                            ", max area ratio " + f(rep.area_before.max) + ", within " +
                            f(options.threshold) + " of 1): zero offsets");
        } else {
            for (const auto& l : rep.levels)
                detail::say(
                    ex, Severity::Info,
                    "correct: level " + std::to_string(l.width) + "x" + std::to_string(l.height) + ": " +
                        std::to_string(l.iterations) + " iteration(s)" +
                        (l.hat_sweeps ? " and " + std::to_string(l.hat_sweeps) + " hat sweep(s)" : "") +
                        (l.global_steps ? " and " + std::to_string(l.global_steps) + " global step(s)" : "") +
                        ", energy " + f(l.energy_start) +
                        (&l == &rep.levels.front() ? ""
                                                   : " (from the coarser offsets x" +
                                                         detail::format_double("%g", l.start_factor) + ")") +
                        " -> " + f(l.energy_end) + (l.converged ? "" : " (iteration limit)") +
                        ", tiles run " + detail::format_double("%.0f%%", 100.0 * l.tiles_run) + ", " +
                        detail::format_double("%.2f s", l.seconds));
            if (!rep.levels.empty() && !rep.levels.back().converged && options.iterations == 0)
                detail::say(ex, Severity::Warning,
                            "correct: stopped at " + std::to_string(options.max_iterations) + " iterations" +
                                counted_as_iterations(rep.levels.back()) +
                                " before the relative energy change fell below " + f(options.tolerance));
            if (rep.polish.iterations > 0)
                detail::say(ex, Severity::Info,
                            "correct: polish of the delivered texel-centre mesh: " +
                                (rep.polish.flipped
                                     ? std::to_string(rep.polish.flipped) +
                                           " flipped triangle(s) of the corner means mended by " +
                                           std::to_string(rep.polish.repairs) + " move(s)" +
                                           (rep.polish.flipped_left
                                                ? " (" + std::to_string(rep.polish.flipped_left) + " left)"
                                                : std::string()) +
                                           ", "
                                     : std::string()) +
                                std::to_string(rep.polish.iterations) + " iteration(s), energy " +
                                f(rep.polish.energy_start) + " -> " + f(rep.polish.energy_end) + ", " +
                                detail::format_double("%.2f s", rep.polish.seconds));
            if (rep.polish.flipped_left > 0)
                detail::say(
                    ex, Severity::Warning,
                    "correct: " + std::to_string(rep.polish.flipped_left) +
                        " triangle(s) of the delivered mesh stay flipped (nodes=center solves that mesh "
                        "itself)");
            detail::say(ex, Severity::Info,
                        "correct: energy " + f(rep.energy_before) + " -> " + f(rep.energy_after) +
                            "; anisotropy s1/s2 mean/p95/max " + f(rep.anisotropy_before.mean) + "/" +
                            f(rep.anisotropy_before.p95) + "/" + f(rep.anisotropy_before.max) + " -> " +
                            f(rep.anisotropy_after.mean) + "/" + f(rep.anisotropy_after.p95) + "/" +
                            f(rep.anisotropy_after.max) + "; area ratio " + f(rep.area_before.mean) + "/" +
                            f(rep.area_before.p95) + "/" + f(rep.area_before.max) + " -> " +
                            f(rep.area_after.mean) + "/" + f(rep.area_after.p95) + "/" +
                            f(rep.area_after.max));
        }
        if (options.report)
            *options.report = rep;

        OIIO::ImageSpec spec(w, h, 2, TypeDesc::FLOAT);
        spec.x = roi.xbegin;
        spec.y = roi.ybegin;
        spec.channelnames = {"du", "dv"};
        spec.attribute("relief:method", "correct");
        spec.attribute("relief:offset_unit", "texture (1 = the width, the height)");
        // Half floats hold an offset to 1/8 texel up to 2048 texels: a writer
        // warns beyond (relief writes -d half when asked).
        spec.attribute("relief:half_max_texels", 2048);
        spec.attribute("relief:boundary", rep.boundary);
        spec.attribute("relief:nodes", rep.nodes);
        spec.attribute("relief:scale", float(p.scale));
        std::ostringstream par;
        par << "scale=" << p.scale << " theta=" << p.theta << " nodes=" << rep.nodes
            << " boundary=" << rep.boundary << " tolerance=" << p.tolerance
            << " iterations=" << (p.iterations ? std::to_string(p.iterations) : "auto")
            << " levels=" << (p.levels ? std::to_string(p.levels) : "auto") << " threshold=" << p.threshold
            << " search=" << search_name(options.search) << " relax=" << p.relax
            << " hats=" << hats_name(options.hats) << " global=" << global_name(options.global)
            << " polish=" << (p.corner_nodes ? p.polish : 0);
        spec.attribute("relief:parameters", par.str());
        detail::set_result(dst, spec, offsets.data());
        return true;
    } catch (const std::exception& e) {
        return detail::fail(dst, "correct", e);
    }
}

}  // namespace relief
