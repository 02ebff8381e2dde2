// SPDX-License-Identifier: Apache-2.0
// The normal map's texels out of an ImageBuf, decoded and turned into slopes
// on the device; what the slope stage chose, reported and recorded.
#include "slope_input.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "results.h"

namespace relief::detail {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

namespace {

bool is_unorm(TypeDesc t)
{
    return t.basetype == TypeDesc::UINT8 || t.basetype == TypeDesc::UINT16 || t.basetype == TypeDesc::UINT32;
}

bool is_float(TypeDesc t)
{
    return t.basetype == TypeDesc::HALF || t.basetype == TypeDesc::FLOAT || t.basetype == TypeDesc::DOUBLE;
}

host::GreenConvention to_host(NormalConvention c)
{
    switch (c) {
    case NormalConvention::OpenGL: return host::GreenConvention::OpenGL;
    case NormalConvention::DirectX: return host::GreenConvention::DirectX;
    default: return host::GreenConvention::Auto;
    }
}

}  // namespace

const char* convention_name(host::GreenConvention c)
{
    return c == host::GreenConvention::DirectX ? "directx" : "opengl";
}

DerivedSlopes derive_slopes(const ImageBuf& normals, ROI roi, const NormalDecoding& decoding,
                            const Execution& exec)
{
    const int nch = normals.spec().nchannels;
    if (nch < 2 || nch > 4)
        throw std::runtime_error("unsupported channel count " + std::to_string(nch) +
                                 ": a normal map needs 2 (XY), 3 (RGB) or 4 (RGBA) channels");
    if (normals.spec().depth > 1)
        throw std::runtime_error("volume images are not supported");

    host::SlopeParams p;
    p.width = roi.width();
    p.height = roi.height();
    p.channels = std::min(nch, 3);
    p.convention = to_host(decoding.convention);
    p.max_angle_deg = decoding.max_angle;

    const TypeDesc stored = normals.nativespec().format;
    const bool unsigned_float = is_float(stored) && decoding.float_encoding == FloatEncoding::Unsigned;
    if (is_unorm(stored) || unsigned_float) {
        p.scale = 2.0f;
        p.bias = -1.0f;
        // The codes either side of the midpoint mean flat (docs/design.md §3 notes).
        if (is_unorm(stored))
            p.zero_band = float(1.001 / (std::ldexp(1.0, int(stored.size() * 8)) - 1.0));
    } else {
        p.scale = 1.0f;  // float, half, and SNORM (OIIO reads it as [-1, 1])
        p.bias = 0.0f;
    }

    // The map is decoded a band of rows at a time, from the image's own
    // pixel type: a whole map widened to floats would be 12 bytes a texel.
    const bool check_signed = is_float(stored) && decoding.float_encoding == FloatEncoding::Signed;
    float lo = 0.0f, hi = 0.0f;
    double mean_x = 0.0, mean_y = 0.0, blue_up = 0.0;
    const host::NormalRows rows = [&](int first, int count, float* out) {
        ROI read = roi;
        read.ybegin = roi.ybegin + first;
        read.yend = read.ybegin + count;
        read.chbegin = 0;
        read.chend = p.channels;
        if (!normals.get_pixels(read, TypeDesc::FLOAT, out))
            throw std::runtime_error("cannot read the normal map's pixels: " + normals.geterror());
        if (check_signed)
            for (std::size_t i = 0, e = std::size_t(count) * p.width * p.channels; i < e; i += p.channels) {
                lo = std::min({lo, out[i], out[i + 1]});
                hi = std::max({hi, out[i], out[i + 1]});
                mean_x += out[i];
                mean_y += out[i + 1];
                if (p.channels == 3) {
                    lo = std::min(lo, out[i + 2]);
                    hi = std::max(hi, out[i + 2]);
                    blue_up += out[i + 2] > 0.5f;
                }
            }
    };

    DerivedSlopes out{host::ComputeContext::acquire(exec.device), host::DeviceSlopes(0, 0, nullptr), {}};
    say(exec, Severity::Info, "device: " + out.context->device().describe());
    out.slopes = host::derive_slopes(*out.context, rows, p, out.stats);
    if (check_signed) {
        // Signed maps centre x and y on 0; a map stored in [0, 1] (what
        // OpenImageIO's get_pixels(FLOAT) makes of an 8-bit file) centres
        // them on 0.5, has every value in [0, 1] and blue mostly above 0.5.
        // Decoding that as signed would tilt every texel. (A flat signed map,
        // x = y = 0, is not taken for one: its x and y centre on 0.)
        const double count = double(p.width) * double(p.height);
        if (lo >= 0.0f && hi <= 1.0f && mean_x / count > 0.25 && mean_y / count > 0.25 &&
            (p.channels < 3 || blue_up > 0.5 * count))
            say(exec, Severity::Warning,
                "float normal map has every value in [0, 1] and x and y centred on 0.5: it looks "
                "stored unsigned, as 8-bit data read as float is; decode it with range=unsigned "
                "(as signed [-1, 1] data, as now, every texel tilts)");
    }

    const auto& s = out.stats;
    if (s.auto_chosen) {
        double lo = std::min(s.curl_opengl, s.curl_directx);
        double hi = std::max(s.curl_opengl, s.curl_directx);
        std::string norms = "curl rms opengl " + format_double("%.4g", s.curl_opengl) + ", directx " +
                            format_double("%.4g", s.curl_directx) + ", ratio " +
                            (lo > 0 ? format_double("%.3g", hi / lo) : std::string("n/a"));
        if (s.ambiguous)
            say(exec, Severity::Warning,
                "normal convention is ambiguous (" + norms + ", under " +
                    format_double("%.3g", host::kAmbiguousCurlRatio) +
                    "): assuming opengl; pass normal=opengl or normal=directx to be sure");
        else
            say(exec, Severity::Notice,
                std::string("normal convention: ") + convention_name(s.chosen) + " (" + norms + ")");
    }
    if (s.invalid > 0)
        say(exec, Severity::Warning,
            std::to_string(s.invalid) +
                " texel(s) had NaN, infinite, zero-length or downward normals and were made flat");
    if (s.clamped > 0)
        say(exec, Severity::Info,
            std::to_string(s.clamped) + " grazing normal(s) clamped to " +
                format_double("%g", decoding.max_angle) + " degrees");
    return out;
}

void tag_slope_metadata(OIIO::ImageSpec& spec, const host::SlopeStats& s)
{
    spec.attribute("relief:normal_convention", convention_name(s.chosen));
    if (s.auto_chosen) {
        spec.attribute("relief:curl_opengl", float(s.curl_opengl));
        spec.attribute("relief:curl_directx", float(s.curl_directx));
    }
    spec.attribute("relief:invalid_normals", int(std::min<std::int64_t>(s.invalid, INT32_MAX)));
    spec.attribute("relief:clamped_normals", int(std::min<std::int64_t>(s.clamped, INT32_MAX)));
}

}  // namespace relief::detail
