// relief::slopes — the DDM derivation family.
#include "relief/slopes.h"

#include <exception>
#include <vector>

#include "error_state.h"
#include "normal_stage.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ImageSpec;
using OIIO::ROI;
using OIIO::TypeDesc;

bool slopes(ImageBuf& dst, const ImageBuf& normals, const SlopeOptions& options, ROI roi,
            int /*nthreads*/)
{
    try {
        roi = detail::resolve_roi(normals, roi);
        auto derived = detail::derive_slopes(normals, roi, options.normals, options.exec);
        std::vector<float> g(std::size_t(roi.width()) * roi.height() * 2);
        host::read_slopes(*derived.context, derived.slopes, g.data());

        ImageSpec spec(roi.width(), roi.height(), 2, TypeDesc::FLOAT);
        spec.x = roi.xbegin;
        spec.y = roi.ybegin;
        spec.channelnames = {"gx", "gy"};
        spec.attribute("relief:method", "slopes");
        spec.attribute("relief:height_unit", "texel");  // slopes: texel per texel step
        detail::tag_slope_metadata(spec, derived.stats);
        dst.reset(spec);
        dst.set_pixels(dst.roi(), TypeDesc::FLOAT, g.data());
        return true;
    } catch (const std::exception& e) {
        detail::set_error(std::string("slopes: ") + e.what());
        dst.errorfmt("slopes: {}", e.what());
        return false;
    }
}

ImageBuf slopes(const ImageBuf& normals, const SlopeOptions& options, ROI roi, int nthreads)
{
    ImageBuf dst;
    slopes(dst, normals, options, roi, nthreads);
    return dst;
}

} // namespace relief
