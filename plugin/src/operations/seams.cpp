// SPDX-License-Identifier: Apache-2.0
#include "seams.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "results.h"

namespace relief::detail {

std::vector<float> channel0(const OIIO::ImageBuf& img, OIIO::ROI roi, const char* what)
{
    std::vector<float> v(std::size_t(roi.width()) * roi.height());
    OIIO::ROI r = roi;
    r.chbegin = 0;
    r.chend = 1;
    if (!img.get_pixels(r, OIIO::TypeDesc::FLOAT, v.data()))
        throw std::runtime_error(std::string("cannot read the ") + what + "'s pixels: " + img.geterror());
    return v;
}

std::vector<float> height_channel(const OIIO::ImageBuf& height, OIIO::ROI roi, const Execution& exec,
                                  const std::string& operation, float scale)
{
    if (height.nchannels() > 1)
        say(exec, Severity::Info,
            operation + ": the height map has " + std::to_string(height.nchannels()) +
                " channels; using channel 0");
    std::vector<float> h = channel0(height, roi, "height map");
    const int w = roi.width();
    float top = 0.0f;
    for (std::size_t i = 0; i < h.size(); ++i) {
        if (!std::isfinite(h[i]))
            throw std::runtime_error("the height map has a NaN or infinite value at texel (" +
                                     std::to_string(i % w) + ", " + std::to_string(i / w) + ")");
        top = std::max(top, std::abs(h[i]));
    }
    if (!std::isfinite(top * scale))
        throw std::runtime_error(operation + ": scale=" + format_double("%g", scale) +
                                 " times the height's largest |value| " + format_double("%g", top) +
                                 " overflows single precision");
    return h;
}

HeightRegion height_region(const OIIO::ImageBuf& height, OIIO::ROI roi, const Execution& exec,
                           const std::string& operation, float scale)
{
    HeightRegion r;
    r.roi = resolve_roi(height, roi);
    r.w = r.roi.width();
    r.h = r.roi.height();
    r.values = height_channel(height, r.roi, exec, operation, scale);
    return r;
}

SeamTest seam_test(const std::vector<float>& h, int w, int ht)
{
    SeamTest t;
    if (w < 2 || ht < 2)
        return t;
    auto at = [&](int x, int y) { return double(h[std::size_t(y) * w + x]); };
    double seam_x = 0, in_x = 0, seam_y = 0, in_y = 0;
    for (int y = 0; y < ht; ++y) {
        seam_x += std::abs(at(0, y) - at(w - 1, y));
        for (int x = 0; x + 1 < w; ++x)
            in_x += std::abs(at(x + 1, y) - at(x, y));
    }
    for (int x = 0; x < w; ++x) {
        seam_y += std::abs(at(x, 0) - at(x, ht - 1));
        for (int y = 0; y + 1 < ht; ++y)
            in_y += std::abs(at(x, y + 1) - at(x, y));
    }
    seam_x /= ht;
    seam_y /= w;
    in_x /= (w - 1) * ht;
    in_y /= (ht - 1) * w;
    t.ratio_x = in_x > 0 ? seam_x / in_x : (seam_x > 0 ? INFINITY : 1.0);
    t.ratio_y = in_y > 0 ? seam_y / in_y : (seam_y > 0 ? INFINITY : 1.0);
    t.periodic = {t.ratio_x <= 2.0, t.ratio_y <= 2.0};
    return t;
}

std::string SeamTest::numbers() const
{
    return "height jump across the wrap seam / mean jump between neighbours: x " +
           format_double("%.2f", ratio_x) + ", y " + format_double("%.2f", ratio_y) +
           "; an axis is periodic at <= 2";
}

std::string wrap_name(Wrap wrap)
{
    const auto word = [](bool periodic) { return periodic ? "periodic" : "free"; };
    return wrap.x == wrap.y ? word(wrap.x) : std::string(word(wrap.x)) + "," + word(wrap.y);
}

namespace {

// The boundary relief:parameters records ("boundary=periodic",
// "boundary=free,periodic", rays' "clip"); false when it records none.
bool recorded_wrap(const std::string& parameters, Wrap& wrap, std::string& text)
{
    const std::string key = "boundary=";
    std::size_t at = parameters.find(key);
    while (at != std::string::npos && at > 0 && parameters[at - 1] != ' ')
        at = parameters.find(key, at + 1);  // a whole word, not "xboundary="
    if (at == std::string::npos)
        return false;
    const std::size_t begin = at + key.size();
    text = parameters.substr(begin, parameters.find(' ', begin) - begin);
    const std::size_t comma = text.find(',');
    const std::string x = text.substr(0, comma), y = comma == std::string::npos ? x : text.substr(comma + 1);
    const auto known = [](const std::string& b) { return b == "periodic" || b == "free" || b == "clip"; };
    if (!known(x) || !known(y))
        return false;
    wrap = {x == "periodic", y == "periodic"};
    return true;
}

}  // namespace

Wrap height_wrap(const OIIO::ImageBuf& height, const std::vector<float>& h, int w, int ht,
                 Boundaries requested, const Execution& exec, const std::string& operation)
{
    Wrap wrap{requested.x == Boundary::Periodic, requested.y == Boundary::Periodic};
    if (requested.x != Boundary::Auto && requested.y != Boundary::Auto)
        return wrap;
    Wrap found;
    std::string recorded;
    if (recorded_wrap(height.spec().get_string_attribute("relief:parameters"), found, recorded)) {
        if (requested.x == Boundary::Auto)
            wrap.x = found.x;
        if (requested.y == Boundary::Auto)
            wrap.y = found.y;
        say(exec, Severity::Info,
            operation + ": boundary " + wrap_name(wrap) +
                " (the height was integrated with boundary=" + recorded + ")");
        return wrap;
    }
    const SeamTest seams = seam_test(h, w, ht);
    if (requested.x == Boundary::Auto)
        wrap.x = seams.periodic.x;
    if (requested.y == Boundary::Auto)
        wrap.y = seams.periodic.y;
    say(exec, Severity::Notice, operation + ": boundary " + wrap_name(wrap) + " (" + seams.numbers() + ")");
    return wrap;
}

}  // namespace relief::detail
