// SPDX-License-Identifier: Apache-2.0
// relief::height — the integration family (normal map -> displacement).
#include "relief/validate.h"
#include "relief/height.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <functional>
#include <climits>
#include <cstdint>
#include <cmath>
#include <exception>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "check/check_stage.h"
#include "height_memory.h"
#include "device/memory_budget.h"
#include "results.h"
#include "slope_input.h"
#include "poisson/poisson_stage.h"
#include "rays/rays_stage.h"
#include "poisson/tiling.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

namespace {

const float kOneWeight = 1.0f;  // stands for "a mask" in the memory estimate

const char* name(Boundary b, bool rays)
{
    switch (b) {
    case Boundary::Auto: return "auto";
    case Boundary::Periodic: return "periodic";
    case Boundary::Free: return rays ? "clip" : "free";
    }
    return "?";
}

// One word when both axes have it, else x's and y's: "periodic,free".
std::string name(Boundaries b, bool rays)
{
    return b.x == b.y ? name(b.x, rays) : std::string(name(b.x, rays)) + "," + name(b.y, rays);
}

// The boundaries an estimate has to cover: an axis left to auto may take
// either.
std::vector<Boundaries> candidates(Boundaries b)
{
    std::vector<Boundaries> all;
    for (Boundary x : {Boundary::Periodic, Boundary::Free})
        for (Boundary y : {Boundary::Periodic, Boundary::Free})
            if ((b.x == Boundary::Auto || b.x == x) && (b.y == Boundary::Auto || b.y == y))
                all.push_back({x, y});
    return all;
}

// Resolves boundary=auto from the slopes' seams, each axis on its own
// (host/tiling: the slope test, then block heights), and says why. Rays
// take one boundary for both axes: periodic when both axes tile.
Boundaries choose_boundary(const HeightOptions& o, const detail::DerivedSlopes& d, bool rays)
{
    if (o.boundary.x != Boundary::Auto && o.boundary.y != Boundary::Auto)
        return o.boundary;
    const int w = d.slopes.width(), h = d.slopes.height();
    host::TilingEvidence e;
    host::with_slopes_on_host(*d.context, d.slopes,
                              [&](const float* g) { e = host::tiling_evidence(g, w, h); });
    const auto verdict = [](bool tiles) { return tiles ? Boundary::Periodic : Boundary::Free; };
    Boundaries b = o.boundary;
    if (rays)
        b = verdict(e.tiles);
    if (b.x == Boundary::Auto)
        b.x = verdict(e.x.tiles);
    if (b.y == Boundary::Auto)
        b.y = verdict(e.y.tiles);
    auto axis = [](const char* name, const host::AxisEvidence& a) {
        return std::string(name) + ": slopes across the wrap seam correlate " +
               detail::format_double("%.2f", a.seam) + " vs " + detail::format_double("%.2f", a.adjacent) +
               " between neighbours (" + (a.slopes_tile ? "pass" : "fail") + "), block heights step " +
               detail::format_double("%.2f", a.height_step) + "x as much across it -> " +
               (a.tiles ? "tiles" : "does not tile");
    };
    detail::say(o.exec, Severity::Notice,
                "boundary: " + name(b, rays) + " (" + axis("x", e.x) + "; " + axis("y", e.y) +
                    (rays && e.x.tiles != e.y.tiles ? "; rays take one boundary for both axes" : "") + ")");
    return b;
}

host::PoissonBoundary poisson_boundary(Boundary b)
{
    return b == Boundary::Free ? host::PoissonBoundary::Free : host::PoissonBoundary::Periodic;
}

// The weights of a mask (empty when it is all ones: nothing to weight).
std::vector<float> mask_weights(const HeightOptions& o, const ImageBuf& normals, ROI roi)
{
    std::vector<float> w(std::size_t(roi.width()) * roi.height());
    if (o.mask_alpha) {
        if (normals.nchannels() != 4)
            throw std::runtime_error("mask=alpha needs a normal map with 4 channels (RGBA), got " +
                                     std::to_string(normals.nchannels()));
        ROI a = roi;
        a.chbegin = 3;
        a.chend = 4;
        if (!normals.get_pixels(a, TypeDesc::FLOAT, w.data()))
            throw std::runtime_error("cannot read the normal map's alpha as a mask: " + normals.geterror());
    } else {
        const ImageBuf& m = *o.mask;
        if (m.spec().width != roi.width() || m.spec().height != roi.height())
            throw std::runtime_error("the mask is " + std::to_string(m.spec().width) + "x" +
                                     std::to_string(m.spec().height) + ", the normal map " +
                                     std::to_string(roi.width()) + "x" + std::to_string(roi.height()));
        ROI a = m.roi();
        a.chbegin = 0;
        a.chend = 1;
        if (!m.get_pixels(a, TypeDesc::FLOAT, w.data()))
            throw std::runtime_error("cannot read the mask: " + m.geterror());
    }
    bool ones = true;
    for (std::size_t i = 0; i < w.size(); ++i) {
        if (!(w[i] >= 0.0f && w[i] <= 1.0f))
            throw std::runtime_error(
                "mask values must be in [0, 1]; texel (" + std::to_string(i % roi.width()) + ", " +
                std::to_string(i / roi.width()) + ") is " + detail::format_double("%g", w[i]));
        ones &= w[i] == 1.0f;
    }
    if (ones)
        w.clear();
    return w;
}

// Refuses, before it is allocated, a height whose slopes, integration grids
// and result do not fit the device and the machine. Called before the
// slopes are derived (boundary=auto: with the boundary that needs less, as
// it is not chosen yet) and again once the boundary is chosen.
void check_memory(const HeightOptions& o, int w, int h, bool slopes_made, std::uint64_t extra_host = 0)
{
    const auto ctx = host::ComputeContext::acquire(o.exec.device);
    const std::uint64_t n = std::uint64_t(w) * std::uint64_t(h);
    const bool taken = o.report == nullptr;  // the round trip needs the slopes after
    const std::vector<Boundaries> boundaries = candidates(o.boundary);
    // The result is taken when the transforms keep only their output grid
    // (and the slopes, if kept); the other stages take it first.
    std::uint64_t device = UINT64_MAX, at_result = 0, host_bytes = 4 * n + extra_host;
    auto consider = [&](std::uint64_t peak, std::uint64_t held_at_result) {
        if (peak < device) {
            device = peak;
            at_result = held_at_result;
        }
    };
    const std::uint64_t grid = 4 * std::uint64_t(w / 2 + 1) * 2 * std::uint64_t(h);
    const std::uint64_t kept_slopes = taken ? 0 : 8 * n;
    for (Boundaries b : boundaries) {
        if (o.method == HeightMethod::Rays && o.impl == RayImpl::Fast) {
            if (b.x != b.y)
                continue;  // (rays take one boundary for both axes)
            host::RayParams p;
            p.boundary = b.x == Boundary::Free ? host::RayBoundary::Clip : host::RayBoundary::Periodic;
            const std::uint64_t peak = host::rays_fast_device_bytes(w, h, p, taken);
            consider(peak, b.x == Boundary::Free ? peak : grid + kept_slopes);
        } else if (o.method == HeightMethod::Rays) {
            consider(12 * n, 12 * n);  // slopes and sums
        } else {
            host::PoissonParams p;
            p.weights = o.mask || o.mask_alpha ? &kOneWeight : nullptr;
            p.boundary_x = poisson_boundary(b.x);
            p.boundary_y = poisson_boundary(b.y);
            const std::uint64_t peak = host::poisson_device_bytes(w, h, p, taken);
            consider(peak, p.weights ? peak : grid + kept_slopes);
        }
    }
    if (o.method == HeightMethod::Rays && o.impl == RayImpl::Fast && o.boundary.x == Boundary::Free)
        host_bytes += 4 * n;  // the convolution's values inside the band
    if (o.method != HeightMethod::Rays && (o.mask || o.mask_alpha))
        host_bytes += 8 * n;  // the weights, and the spectral start
    host::check_memory(
        *ctx,
        std::string(o.method == HeightMethod::Rays ? "ray integration" : "the Poisson integration") +
            " of a " + std::to_string(w) + "x" + std::to_string(h) + " map",
        device, host_bytes, slopes_made ? 8 * n : 0, at_result);
}

}  // namespace

void detail::check_height_memory(const HeightOptions& options, int w, int h, std::uint64_t extra_host)
{
    HeightOptions o = options;
    if (o.method == HeightMethod::Auto)
        o.method = HeightMethod::Poisson;
    check_memory(o, w, h, false, extra_host);
}

std::string HeightReport::to_json() const
{
    nlohmann::ordered_json j;
    j["width"] = width;
    j["height"] = height;
    j["method"] = method;
    j["normal_convention"] = normal_convention;
    j["boundary"] = boundary;
    j["round_trip"] = {
        {"angular_error_deg",
         {{"mean", angular_error_mean}, {"p95", angular_error_p95}, {"max", angular_error_max}}},
        {"residual_share", residual_share}};
    j["seconds"] = seconds;
    return j.dump(2) + "\n";
}

std::string describe(const HeightOptions& o)
{
    std::ostringstream ss;
    const bool rays = o.method == HeightMethod::Rays;
    ss << "method=" << (rays ? "rays" : o.method == HeightMethod::Poisson ? "poisson" : "auto");
    if (rays)
        ss << " impl=" << (o.impl == RayImpl::Fast ? "fast" : "reference") << " rays=" << o.rays
           << " radius=" << o.radius << " phase=" << o.phase
           << " directions=" << (o.directions == RayDirections::Rational ? "rational" : "exact");
    ss << " boundary=" << name(o.boundary, rays);
    if (!rays)
        ss << " highpass=" << o.highpass;
    if (o.mask_alpha)
        ss << " mask=alpha";
    else if (o.mask)
        ss << " mask=image";
    return ss.str();
}

ImageBuf height(const ImageBuf& normals, const HeightOptions& options, ROI roi, int nthreads)
{
    return detail::first_form([&](ImageBuf& dst) { height(dst, normals, options, roi, nthreads); });
}

bool height(ImageBuf& dst, const ImageBuf& normals, const HeightOptions& options, ROI roi, int /*nthreads*/)
{
    return detail::guarded(dst, "height", options.exec, options, [&] {
        const auto t0 = std::chrono::steady_clock::now();
        roi = detail::resolve_roi(normals, roi);
        HeightOptions chosen = options;
        if (chosen.method == HeightMethod::Auto)
            chosen.method = HeightMethod::Poisson;
        const bool rays = chosen.method == HeightMethod::Rays;
        check_memory(chosen, roi.width(), roi.height(), false);
        // Progress by stage (the slopes, the boundary's tests, the
        // integration, which the rays report within their share), so that a
        // host's progress, and the C ABI's cancel that answers it, come
        // between the stages and not only at the ends.
        const std::function<void(double)> progress = detail::marked(options.exec.on_progress);
        const auto at = [&](double fraction) {
            if (progress)
                progress(fraction);
        };
        auto derived = detail::derive_slopes(normals, roi, options.normals, options.exec);
        at(0.2);
        if (options.method == HeightMethod::Auto)
            detail::say(options.exec, Severity::Info, "method: poisson (the default; method=rays for rays)");
        chosen.boundary = choose_boundary(chosen, derived, rays);
        if (chosen.boundary != options.boundary)
            check_memory(chosen, roi.width(), roi.height(), true);
        at(0.35);
        const std::function<void(double)> integration =
            progress ? std::function<void(double)>([&](double f) { at(0.35 + 0.55 * f); }) : nullptr;

        // The result's memory is taken when the stage has it ready, after
        // its grids are freed; without a report to make, the stage also
        // takes the slopes over and frees them as soon as it can.
        ImageBuf result;
        const host::HeightSink sink = [&] {
            result = detail::make_result(roi, {"Y"});
            return static_cast<float*>(result.localpixels());
        };
        auto slopes_for_stage = [&] {
            return options.report ? host::DeviceSlopes(derived.slopes) : std::move(derived.slopes);
        };
        if (rays) {
            host::RayParams p;
            p.rays = chosen.rays;
            p.radius = chosen.radius;
            p.phase = chosen.phase;
            p.directions = chosen.directions == RayDirections::Rational ? host::DirectionSet::Rational
                                                                        : host::DirectionSet::Exact;
            // (validate() gives rays one boundary for both axes)
            p.boundary =
                chosen.boundary.x == Boundary::Free ? host::RayBoundary::Clip : host::RayBoundary::Periodic;
            p.skip_flat = chosen.skip_flat;
            host::RayReport report;
            if (chosen.impl == RayImpl::Fast)
                host::integrate_rays_fast(*derived.context, slopes_for_stage(), p, sink, integration,
                                          &report);
            else
                host::integrate_rays_reference(*derived.context, derived.slopes, p, sink(), integration,
                                               &report);
            if (p.skip_flat)
                detail::say(options.exec, Severity::Info,
                            "rays: skipped " + std::to_string(report.skipped) + " of " +
                                std::to_string(report.tiles) + " tiles of " +
                                std::to_string(host::kSkipTile) + "x" + std::to_string(host::kSkipTile) +
                                " texels (zero slopes within the radius)");
        } else {
            host::PoissonParams p;
            p.boundary_x = poisson_boundary(chosen.boundary.x);
            p.boundary_y = poisson_boundary(chosen.boundary.y);
            p.highpass = chosen.highpass;
            std::vector<float> weights;
            if (chosen.mask || chosen.mask_alpha) {
                weights = mask_weights(chosen, normals, roi);
                if (weights.empty())
                    detail::say(options.exec, Severity::Info, "mask: all ones, nothing to weight");
                else
                    p.weights = weights.data();
            }
            host::PoissonReport report;
            host::integrate_poisson(*derived.context, slopes_for_stage(), p, sink, &report);
            if (p.weights)
                detail::say(options.exec, Severity::Info,
                            "poisson: weighted solve, " + std::to_string(report.iterations) +
                                " conjugate-gradient iterations, relative residual " +
                                detail::format_double("%.2g", report.residual));
        }
        at(0.9);
        if (HeightReport* r = options.report) {
            const host::RoundTrip t = host::round_trip(
                *derived.context, derived.slopes, static_cast<const float*>(result.localpixels()),
                chosen.boundary.x == Boundary::Periodic, chosen.boundary.y == Boundary::Periodic);
            r->method = rays ? "rays" : "poisson";
            r->normal_convention = detail::convention_name(derived.stats.chosen);
            r->boundary = name(chosen.boundary, rays);
            r->width = roi.width();
            r->height = roi.height();
            r->angular_error_mean = t.mean_deg;
            r->angular_error_p95 = t.p95_deg;
            r->angular_error_max = t.max_deg;
            r->residual_share = t.residual_share;
            detail::say(options.exec, Severity::Info,
                        "height: round trip: angular error mean " +
                            detail::format_double("%.3g", t.mean_deg) + " deg, p95 " +
                            detail::format_double("%.3g", t.p95_deg) + ", max " +
                            detail::format_double("%.3g", t.max_deg) + "; residual share " +
                            detail::format_double("%.3g", t.residual_share) +
                            " (the part of the slopes the height does not reproduce)");
        }
        detail::publish_result(dst, std::move(result), rays ? "rays" : "poisson", derived.stats,
                               describe(chosen));
        if (options.report)
            options.report->seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return true;
    });
}

}  // namespace relief
