// SPDX-License-Identifier: Apache-2.0
// What every operation does with its result, its messages and its failure.
#include "results.h"

#include <cstdio>

#include "error_state.h"
#include "slope_input.h"

namespace relief::detail {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

std::string format_double(const char* fmt, double v)
{
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return buf;
}

void say(const Execution& exec, Severity s, const std::string& msg)
{
    if (exec.on_message) {
        const InCallback in;
        exec.on_message(s, msg);
    }
}

ROI resolve_roi(const ImageBuf& image, ROI roi)
{
    if (!image.initialized())
        throw std::runtime_error("the input image is empty (nothing was read into it)");
    if (image.has_error())
        throw std::runtime_error(image.geterror());
    ROI all = image.roi();
    if (!roi.defined())
        return all;
    ROI r = OIIO::roi_intersection(roi, all);
    r.zbegin = all.zbegin;
    r.zend = all.zend;
    if (r.width() <= 0 || r.height() <= 0)
        throw std::runtime_error("the ROI does not overlap the image");
    return r;
}

ImageBuf make_result(ROI roi, std::vector<std::string> channels)
{
    OIIO::ImageSpec spec(roi.width(), roi.height(), int(channels.size()), TypeDesc::FLOAT);
    spec.x = roi.xbegin;
    spec.y = roi.ybegin;
    spec.channelnames = std::move(channels);
    return ImageBuf(spec, OIIO::InitializePixels::No);
}

void publish_result(ImageBuf& dst, ImageBuf&& result, const char* method, const host::SlopeStats& stats,
                    const std::string& parameters)
{
    OIIO::ImageSpec& spec = result.specmod();
    spec.attribute("relief:method", method);
    if (!parameters.empty())
        spec.attribute("relief:parameters", parameters);
    spec.attribute("relief:height_unit", "texel");
    tag_slope_metadata(spec, stats);
    dst = std::move(result);
}

void publish_result(ImageBuf& dst, ROI roi, std::vector<std::string> channels, const char* method,
                    const host::SlopeStats& stats, const float* pixels, const std::string& parameters)
{
    OIIO::ImageSpec spec(roi.width(), roi.height(), int(channels.size()), TypeDesc::FLOAT);
    spec.x = roi.xbegin;
    spec.y = roi.ybegin;
    spec.channelnames = std::move(channels);
    spec.attribute("relief:method", method);
    if (!parameters.empty())
        spec.attribute("relief:parameters", parameters);
    spec.attribute("relief:height_unit", "texel");
    tag_slope_metadata(spec, stats);
    set_result(dst, spec, pixels);
}

void set_result(ImageBuf& dst, const OIIO::ImageSpec& spec, const float* pixels)
{
    dst.reset(spec);
    dst.set_pixels(dst.roi(), TypeDesc::FLOAT, pixels);
}

bool fail(ImageBuf& dst, const char* operation, const std::exception& e)
{
    set_error(std::string(operation) + ": " + e.what());
    dst.errorfmt("{}: {}", operation, e.what());
    return false;
}

}  // namespace relief::detail
