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
#include "correct_params.h"
#include "results.h"
#include "seams.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

namespace {

// What the iteration limit counted besides the nodes' iterations.
std::string counted_as_iterations(const CorrectLevelReport& l)
{
    const std::string what = l.hat_sweeps && l.global_steps ? "each hat sweep and global step"
                             : l.hat_sweeps                 ? "each hat sweep"
                             : l.global_steps               ? "each global step"
                                                            : "";
    return what.empty() ? what : " (" + what + " counted as the iterations it costs)";
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
    return detail::guarded(dst, "correct", options.exec, options, [&] {
        const auto t0 = std::chrono::steady_clock::now();
        const auto& [at, w, h, heights] = detail::height_region(height, roi, options.exec, "correct");

        const detail::CorrectCall call = detail::correct_call(height, heights, w, h, options);
        const host::CorrectParams p = call.params();

        auto ctx = host::ComputeContext::acquire(options.exec.device);
        detail::say(options.exec, Severity::Info, "device: " + ctx->device().describe());
        std::vector<float> offsets(2 * std::size_t(w) * h);
        host::CorrectReport hr;
        host::correct_distortion(*ctx, heights.data(), w, h, p, offsets.data(), &hr,
                                 detail::marked(options.exec.on_progress));

        CorrectReport rep = detail::correct_report(hr, call, w, h);
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
        spec.x = at.xbegin;
        spec.y = at.ybegin;
        spec.channelnames = {"du", "dv"};
        spec.attribute("relief:method", "correct");
        spec.attribute("relief:offset_unit", "texture (1 = the width, the height)");
        // Half floats hold an offset to 1/8 texel up to 2048 texels: a writer
        // warns beyond (relief writes -d half when asked).
        spec.attribute("relief:half_max_texels", 2048);
        spec.attribute("relief:boundary", rep.boundary);
        spec.attribute("relief:nodes", rep.nodes);
        spec.attribute("relief:scale", float(p.scale));
        spec.attribute("relief:parameters", detail::correct_parameters(call, options));
        detail::set_result(dst, spec, offsets.data());
        return true;
    });
}

}  // namespace relief
