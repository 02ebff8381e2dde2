// SPDX-License-Identifier: Apache-2.0
// relief::normals and relief::tessellation — checking a height (docs/design.md §9).
#include "relief/validate.h"
#include "relief/check.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "check/check_stage.h"
#include "options/option_limits.h"
#include "device/compute_context.h"
#include "results.h"
#include "seams.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

ImageBuf normals(const ImageBuf& height, const NormalsOptions& options, ROI roi, int nthreads)
{
    return detail::first_form([&](ImageBuf& dst) { normals(dst, height, options, roi, nthreads); });
}

bool normals(ImageBuf& dst, const ImageBuf& height, const NormalsOptions& options, ROI roi, int)
{
    return detail::guarded(dst, "normals", options.exec, options, [&] {
        const auto& [at, w, ht, h] =
            detail::height_region(height, roi, options.exec, "normals", options.scale);
        const detail::Wrap wrap =
            detail::height_wrap(height, h, w, ht, options.boundary, options.exec, "normals");
        auto ctx = host::ComputeContext::acquire(options.exec.device);
        std::vector<float> n(3 * h.size());
        const bool directx = options.convention == NormalConvention::DirectX;
        host::height_normals(*ctx, h.data(), w, ht, wrap.x, wrap.y, options.scale, directx, n.data());

        OIIO::ImageSpec spec(w, ht, 3, TypeDesc::FLOAT);
        spec.x = at.xbegin;
        spec.y = at.ybegin;
        spec.channelnames = {"R", "G", "B"};
        spec.attribute("relief:method", "normals");
        spec.attribute("relief:normal_convention", directx ? "directx" : "opengl");
        spec.attribute("relief:parameters", std::string("normal=") + (directx ? "directx" : "opengl") +
                                                " scale=" + detail::number_text(options.scale) +
                                                " boundary=" + detail::wrap_name(wrap));
        detail::set_result(dst, spec, n.data());
        return true;
    });
}

ImageBuf tessellation(const ImageBuf& height, const TessellationOptions& options, ROI roi, int nthreads)
{
    return detail::first_form([&](ImageBuf& dst) { tessellation(dst, height, options, roi, nthreads); });
}

bool tessellation(ImageBuf& dst, const ImageBuf& height, const TessellationOptions& options, ROI roi, int)
{
    return detail::guarded(dst, "tessellation", options.exec, options, [&] {
        const auto& [at, w, ht, h] =
            detail::height_region(height, roi, options.exec, "tessellation", options.scale);
        auto ctx = host::ComputeContext::acquire(options.exec.device);
        std::vector<std::uint8_t> levels =
            host::tessellation_levels(*ctx, h.data(), w, ht, options.patch, options.error, options.scale);
        const int px = (w + options.patch - 1) / options.patch, py = (ht + options.patch - 1) / options.patch;

        // The share of patches per level, and those no level brings within E.
        std::vector<std::size_t> count(host::kMaxTessellationLevel + 1, 0);
        for (std::uint8_t L : levels)
            ++count[L];
        std::vector<float> pixels(levels.size());
        for (std::size_t i = 0; i < levels.size(); ++i)
            pixels[i] = levels[i] ? float(levels[i]) : float(host::kMaxTessellationLevel);
        if (count[0] > 0)
            detail::say(options.exec, Severity::Warning,
                        "tessellation: " + std::to_string(count[0]) + " of " + std::to_string(levels.size()) +
                            " patch(es) exceed error=" + detail::format_double("%g", options.error) +
                            " even at level 64; they get 64 (use a smaller patch)");
        std::string shares;
        for (int L = 1; L <= host::kMaxTessellationLevel; ++L)
            if (count[L] > 0)
                shares += (shares.empty() ? "" : ", ") + std::string("level ") + std::to_string(L) + " " +
                          detail::format_double("%.1f%%", 100.0 * double(count[L]) / double(levels.size()));
        if (count[0] > 0)
            shares += (shares.empty() ? "" : ", ") + std::string("none within E (set to 64) ") +
                      detail::format_double("%.1f%%", 100.0 * double(count[0]) / double(levels.size()));
        detail::say(options.exec, Severity::Info,
                    "tessellation: " + std::to_string(px) + "x" + std::to_string(py) + " patches of " +
                        std::to_string(options.patch) + " texels: " + shares);

        OIIO::ImageSpec spec(px, py, 1, TypeDesc::FLOAT);
        spec.channelnames = {"L"};
        spec.attribute("relief:method", "tessellation");
        spec.attribute("relief:patch", options.patch);
        spec.attribute("relief:error", options.error);
        spec.attribute("relief:scale", options.scale);
        // (numbers as the modifiers write them: error=0.1, not 0.100000001)
        spec.attribute("relief:parameters", "patch=" + std::to_string(options.patch) +
                                                " error=" + detail::number_text(options.error) +
                                                " scale=" + detail::number_text(options.scale));
        detail::set_result(dst, spec, pixels.data());
        return true;
    });
}

}  // namespace relief
