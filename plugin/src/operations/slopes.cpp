// SPDX-License-Identifier: Apache-2.0
// relief::slopes — the DDM derivation family.
#include "relief/validate.h"
#include "relief/slopes.h"

#include <exception>
#include <vector>

#include "results.h"
#include "slope_input.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

ImageBuf slopes(const ImageBuf& normals, const SlopeOptions& options, ROI roi, int nthreads)
{
    return detail::first_form([&](ImageBuf& dst) { slopes(dst, normals, options, roi, nthreads); });
}

bool slopes(ImageBuf& dst, const ImageBuf& normals, const SlopeOptions& options, ROI roi, int /*nthreads*/)
{
    return detail::guarded(dst, "slopes", options.exec, options, [&] {
        roi = detail::resolve_roi(normals, roi);
        auto derived = detail::derive_slopes(normals, roi, options.normals, options.exec);
        std::vector<float> g(std::size_t(roi.width()) * roi.height() * 2);
        host::read_slopes(*derived.context, derived.slopes, g.data());

        // The unit of a slope is texel per texel step: heights in texels.
        detail::publish_result(dst, roi, {"gx", "gy"}, "slopes", derived.stats, g.data());
        return true;
    });
}

}  // namespace relief
