// relief::height — the integration family (normal map -> displacement).
#include "relief/height.h"

#include <cmath>
#include <exception>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "normal_stage.h"
#include "ray_stage.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

std::string describe(const HeightOptions& o)
{
    std::ostringstream ss;
    ss << "impl=reference rays=" << o.rays << " radius=" << o.radius << " phase=" << o.phase
       << " directions=exact boundary=" << (o.boundary == Boundary::Clip ? "clip" : "periodic");
    return ss.str();
}

namespace {

void validate(const HeightOptions& o)
{
    if (o.rays < 1 || o.rays > 4096)
        throw std::invalid_argument("rays must be an integer in [1, 4096], got " +
                                    std::to_string(o.rays));
    if (!(o.radius > 0.0f) || !std::isfinite(o.radius) || o.radius > 65536.0f)
        throw std::invalid_argument("radius must be in (0, 65536] texels");
    if (!(o.phase >= 0.0f && o.phase < 1.0f))
        throw std::invalid_argument("phase must be in [0, 1)");
}

} // namespace

bool height(ImageBuf& dst, const ImageBuf& normals, const HeightOptions& options, ROI roi,
            int /*nthreads*/)
{
    try {
        validate(options);
        roi = detail::resolve_roi(normals, roi);
        auto derived = detail::derive_slopes(normals, roi, options.normals, options.exec);

        host::RayParams p;
        p.rays = options.rays;
        p.radius = options.radius;
        p.phase = options.phase;
        p.directions = host::DirectionSet::Exact;
        p.boundary = options.boundary == Boundary::Clip ? host::RayBoundary::Clip
                                                        : host::RayBoundary::Periodic;
        std::vector<float> h(std::size_t(roi.width()) * roi.height());
        host::integrate_rays_reference(*derived.context, derived.slopes, p, h.data(),
                                       options.exec.on_progress);

        detail::publish_result(dst, roi, {"Y"}, "rays", derived.stats, h.data(), describe(options));
        return true;
    } catch (const std::exception& e) {
        return detail::fail(dst, "height", e);
    }
}

ImageBuf height(const ImageBuf& normals, const HeightOptions& options, ROI roi, int nthreads)
{
    ImageBuf dst;
    height(dst, normals, options, roi, nthreads);
    return dst;
}

} // namespace relief
