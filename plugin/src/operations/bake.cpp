// SPDX-License-Identifier: Apache-2.0
// relief::bake — resampling a texture at u + c(u), colour-managed.
#include "relief/validate.h"
#include "relief/bake.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "bake/bake_stage.h"
#include "io/colour.h"
#include "device/compute_context.h"
#include "results.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ROI;
using OIIO::TypeDesc;

namespace {

std::string lower(std::string s)
{
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

bool name_has(const std::string& name, std::initializer_list<const char*> words)
{
    const std::string stem = lower(std::filesystem::path(name).filename().string());  // NOLINT
    for (const char* w : words)
        if (stem.find(w) != std::string::npos)
            return true;
    return false;
}

// Unit vectors stored as 2v - 1 with +z up: a tangent-space normal map.
bool looks_like_normals(const std::vector<float>& px, int nch)
{
    if (nch < 3)
        return false;
    const std::size_t n = px.size() / nch;
    std::size_t unit = 0;
    double z = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const double x = 2.0 * px[i * nch] - 1, y = 2.0 * px[i * nch + 1] - 1, zz = 2.0 * px[i * nch + 2] - 1;
        const double len = std::sqrt(x * x + y * y + zz * zz);
        unit += std::abs(len - 1.0) < 0.1;
        z += zz;
    }
    return n > 0 && unit >= 0.95 * n && z / n > 0.5;
}

BakeKind resolve_kind(const BakeOptions& o, const ImageBuf& tex, const std::vector<float>& px, int nch)
{
    if (o.kind != BakeKind::Auto)
        return o.kind;
    const std::string method = tex.spec().get_string_attribute("relief:method");
    if (method == "rays" || method == "poisson")
        return BakeKind::Height;
    if (method == "normals")
        return BakeKind::Normal;
    if (nch == 1 && name_has(tex.name(), {"height", "disp", "bump", "depth"}))
        return BakeKind::Height;
    if (name_has(tex.name(), {"normal", "nrm"}) || looks_like_normals(px, nch))
        return BakeKind::Normal;
    return o.colorspace == BakeColorspace::Raw ? BakeKind::Data : BakeKind::Color;
}

// The colour space to decode from, or "" for none (linear or raw).
std::string resolve_space(const BakeOptions& o, const ImageBuf& tex)
{
    switch (o.colorspace) {
    case BakeColorspace::SRGB: return "sRGB";
    case BakeColorspace::Linear:
    case BakeColorspace::Raw: return "";
    case BakeColorspace::Auto: break;
    }
    const TypeDesc stored = tex.nativespec().format;
    const bool integer = stored.basetype == TypeDesc::UINT8 || stored.basetype == TypeDesc::UINT16;
    const std::string ext = lower(std::filesystem::path(tex.name()).extension().string());
    if (stored == TypeDesc::UINT8 && (ext == ".png" || ext == ".jpg" || ext == ".jpeg"))
        return "sRGB";
    const std::string declared = tex.spec().get_string_attribute("oiio:ColorSpace");
    const std::string d = lower(declared);
    if (d == "srgb")
        return "sRGB";
    if (d == "linear" || d == "scene_linear" || d == "lin_rec709" || d == "raw" || d == "data")
        return "";
    if (declared.empty())  // undeclared: integer colour is sRGB, float is linear
        return integer ? "sRGB" : "";
    return declared;
}

}  // namespace

ImageBuf bake(const ImageBuf& texture, const ImageBuf& offsets, const BakeOptions& options, ROI roi,
              int nthreads)
{
    return detail::first_form([&](ImageBuf& dst) { bake(dst, texture, offsets, options, roi, nthreads); });
}

bool bake(ImageBuf& dst, const ImageBuf& texture, const ImageBuf& offsets, const BakeOptions& options,
          ROI roi, int /*nthreads*/)
{
    return detail::guarded(dst, "bake", options.exec, options, [&] {
        roi = detail::resolve_roi(texture, roi);
        const int w = roi.width(), h = roi.height(), nch = texture.nchannels();
        // Exactly 2 channels, or more only when relief's metadata says they
        // are offsets: a normal map given by mistake must not be used as one.
        const bool ours = offsets.spec().get_string_attribute("relief:method") == "correct";
        if (offsets.nchannels() < 2 || (offsets.nchannels() > 2 && !ours))
            throw std::runtime_error("the offset map has " + std::to_string(offsets.nchannels()) +
                                     " channel(s); it needs 2 (du, dv in texture units, as "
                                     "--correct writes them)");
        if (offsets.spec().width != w || offsets.spec().height != h)
            throw std::runtime_error("the offset map is " + std::to_string(offsets.spec().width) + "x" +
                                     std::to_string(offsets.spec().height) + ", the texture " +
                                     std::to_string(w) + "x" + std::to_string(h) +
                                     "; compute the offsets at the texture's size");
        std::vector<float> off(2 * std::size_t(w) * h);
        ROI oroi = offsets.roi();
        oroi.chbegin = 0;
        oroi.chend = 2;
        if (!offsets.get_pixels(oroi, TypeDesc::FLOAT, off.data()))
            throw std::runtime_error("cannot read the offset map: " + offsets.geterror());
        for (float v : off)
            if (!std::isfinite(v))
                throw std::runtime_error("the offset map has NaN or infinite values");

        std::vector<float> px(std::size_t(w) * h * nch);
        ROI troi = roi;
        troi.chbegin = 0;
        troi.chend = nch;
        if (!texture.get_pixels(troi, TypeDesc::FLOAT, px.data()))
            throw std::runtime_error("cannot read the texture: " + texture.geterror());
        host::stop_if_cancelled();  // (between the host's passes: each is tens of ms at 1024^2)

        const BakeKind kind = resolve_kind(options, texture, px, nch);
        if (kind == BakeKind::Height)
            throw std::runtime_error(
                "refusing to bake a displacement (height) map: its texels must stay where they "
                "are, the offsets are computed from it (pass kind=data if this is not a height map)");
        // Auto: as the correction's boundary per axis ("periodic,fixed":
        // wrap along x, clamp along y).
        const std::string boundary = offsets.spec().get_string_attribute("relief:boundary");
        const std::size_t comma = boundary.find(',');
        const std::string bx = boundary.substr(0, comma),
                          by = comma == std::string::npos ? bx : boundary.substr(comma + 1);
        const host::Periodic periodic = options.wrap == BakeWrap::Auto
                                            ? host::Periodic(bx == "periodic", by == "periodic")
                                            : host::Periodic(options.wrap == BakeWrap::Periodic);
        std::string space;
        if (kind == BakeKind::Color)
            space = resolve_space(options, texture);
        const char* kind_name = kind == BakeKind::Color    ? "colour"
                                : kind == BakeKind::Normal ? "normal map (data, renormalised)"
                                                           : "data";
        detail::say(options.exec, Severity::Notice,
                    std::string("bake: ") + std::string(texture.name()) + " as " + kind_name +
                        (kind == BakeKind::Color ? (space.empty() ? std::string(", linear")
                                                                  : ", " + space + " decoded to linear by " +
                                                                        detail::colour_engine())
                                                 : std::string()) +
                        ", " + (options.filter == BakeFilter::Bicubic ? "bicubic" : "bilinear") + ", " +
                        (periodic.x && periodic.y ? "wrapping"
                         : periodic.x             ? "wrapping along x, clamped at the top and bottom"
                         : periodic.y             ? "wrapping along y, clamped at the left and right"
                                                  : "clamped at the edges"));

        if (!space.empty())
            detail::to_linear(px, nch, space);
        auto ctx = host::ComputeContext::acquire(options.exec.device);
        std::vector<float> out(px.size());
        host::bake_gather(*ctx, px.data(), w, h, nch, off.data(), periodic,
                          options.filter == BakeFilter::Bicubic ? host::BakeFilter::Bicubic
                                                                : host::BakeFilter::Bilinear,
                          out.data());
        if (!space.empty())
            detail::from_linear(out, nch, space);
        host::stop_if_cancelled();
        if (kind == BakeKind::Normal) {
            // Interpolated unit vectors are shorter: renormalise (UNORM-style
            // encodings in [0, 1], signed float maps as they are).
            const bool unorm = texture.nativespec().format.basetype != TypeDesc::FLOAT &&
                               texture.nativespec().format.basetype != TypeDesc::HALF;
            for (std::size_t i = 0; i < std::size_t(w) * h; ++i) {
                float v[3];
                for (int c = 0; c < 3; ++c)
                    v[c] = unorm ? 2.0f * out[i * nch + c] - 1.0f : out[i * nch + c];
                const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
                if (len > 0.0f)
                    for (int c = 0; c < 3; ++c) {
                        const float n = v[c] / len;
                        out[i * nch + c] = unorm ? 0.5f * n + 0.5f : n;
                    }
            }
        }
        OIIO::ImageSpec spec = texture.spec();
        spec.width = spec.full_width = w;
        spec.height = spec.full_height = h;
        spec.x = roi.xbegin;
        spec.y = roi.ybegin;
        spec.set_format(TypeDesc::FLOAT);
        spec.attribute("relief:native_format", texture.nativespec().format.c_str());
        spec.attribute("relief:baked", std::string(kind_name) + (space.empty() ? "" : ", " + space));
        detail::set_result(dst, spec, out.data());
        return true;
    });
}

}  // namespace relief
