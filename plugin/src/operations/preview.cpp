// SPDX-License-Identifier: Apache-2.0
// relief::preview — a labelled sheet that shows whether a height is right
// (docs/design.md §9). The device derives the slopes, the height's normals and the
// round trip (the same code as --normals and --report); lighting and
// layout are display work on the host.
#include "relief/validate.h"
#include "relief/preview.h"

#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <vector>

#include "check/check_stage.h"
#include "io/colour.h"
#include "results.h"
#include "slope_input.h"
#include "relief/errors.h"
#include "relief/imageio.h"
#include "seams.h"

namespace relief {

using OIIO::ImageBuf;
using OIIO::ImageSpec;
using OIIO::ROI;
using OIIO::TypeDesc;
namespace IBA = OIIO::ImageBufAlgo;

namespace {

constexpr const char* kFont = "DejaVuSans";  // Debian's fonts-dejavu-core
constexpr int kMargin = 16, kCaption = 34, kBar = 52, kFontSize = 18;

// Real spherical harmonics up to l = 2 at unit direction d.
void sh_basis(double x, double y, double z, double Y[9])
{
    Y[0] = 0.282095;
    Y[1] = 0.488603 * y;
    Y[2] = 0.488603 * z;
    Y[3] = 0.488603 * x;
    Y[4] = 1.092548 * x * y;
    Y[5] = 1.092548 * y * z;
    Y[6] = 0.315392 * (3 * z * z - 1);
    Y[7] = 1.092548 * x * z;
    Y[8] = 0.546274 * (x * x - y * y);
}

// Projects w x h linear RGB radiance (lat-long) onto the basis.
SphericalHarmonics project(const std::vector<float>& rgb, int w, int h)
{
    double acc[9][3] = {};
    for (int j = 0; j < h; ++j) {
        const double theta = M_PI * (j + 0.5) / h;  // from the zenith
        const double domega = (2 * M_PI / w) * (M_PI / h) * std::sin(theta);
        for (int i = 0; i < w; ++i) {
            const double phi = 2 * M_PI * (i + 0.5) / w;
            double Y[9];
            // Image frame: x right, y down (so the azimuth turns toward -y), z up.
            sh_basis(std::sin(theta) * std::cos(phi), -std::sin(theta) * std::sin(phi), std::cos(theta), Y);
            const float* L = &rgb[3 * (std::size_t(j) * w + i)];
            for (int k = 0; k < 9; ++k)
                for (int c = 0; c < 3; ++c)
                    acc[k][c] += L[c] * Y[k] * domega;
        }
    }
    SphericalHarmonics sh;
    for (int k = 0; k < 9; ++k)
        for (int c = 0; c < 3; ++c)
            sh.c[k][c] = float(acc[k][c]);
    return sh;
}

struct Rgb {
    float r, g, b;
};

Rgb ramp(const std::vector<Rgb>& stops, double t)
{
    t = std::clamp(t, 0.0, 1.0) * double(stops.size() - 1);
    const std::size_t i = std::min(std::size_t(t), stops.size() - 2);
    const float f = float(t - double(i));
    const Rgb a = stops[i], b = stops[i + 1];
    return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b)};
}

// Approximations of matplotlib's inferno (heat) and viridis (height).
const std::vector<Rgb> kHeat = {{0.0f, 0.0f, 0.02f},
                                {0.34f, 0.06f, 0.38f},
                                {0.73f, 0.21f, 0.33f},
                                {0.98f, 0.55f, 0.04f},
                                {0.99f, 1.0f, 0.64f}};
const std::vector<Rgb> kViridis = {{0.27f, 0.0f, 0.33f},
                                   {0.23f, 0.32f, 0.55f},
                                   {0.13f, 0.57f, 0.55f},
                                   {0.37f, 0.79f, 0.38f},
                                   {0.99f, 0.91f, 0.14f}};

// The value of rank q (0..1) of v (a copy is partially sorted).
double quantile(std::vector<float> v, double q)
{
    if (v.empty())
        return 0.0;
    const std::size_t k = std::min(v.size() - 1, std::size_t(q * double(v.size())));
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
    return v[k];
}

// A float RGB panel (display values) resized to pw x ph: filtered when
// smaller, nearest texels when larger (a small map stays crisp).
ImageBuf fit(const std::vector<float>& rgb, int w, int h, int pw, int ph)
{
    ImageBuf src(ImageSpec(w, h, 3, TypeDesc::FLOAT));
    src.set_pixels(src.roi(), TypeDesc::FLOAT, rgb.data());
    if (pw == w && ph == h)
        return src;
    ImageBuf dst(ImageSpec(pw, ph, 3, TypeDesc::FLOAT));
    const bool ok = pw < w ? IBA::resize(dst, src, "box", 0.0f) : IBA::resample(dst, src, false);
    if (!ok)
        throw std::runtime_error("cannot resize a panel: " + dst.geterror());
    return dst;
}

// The sheet: 3 x 2 cells, each a caption, a panel of pw x ph and room for
// a colour bar. Cells are at least kMinCell wide and tall whatever the
// panels (a 65536x1 map has panels 1 texel tall): the captions and the
// statistics' text must fall inside the image (OIIO 2.4's render_text
// aborts on text that runs off its bottom).
constexpr int kMinCellWidth = 344, kMinCellHeight = 100;

class Sheet {
public:
    Sheet(int pw, int ph) : ph_(ph), cw_(std::max(pw, kMinCellWidth)), ch_(std::max(ph, kMinCellHeight))
    {
        const int cell_h = kCaption + ch_ + kBar;
        ImageSpec spec(3 * cw_ + 4 * kMargin, 2 * cell_h + 3 * kMargin, 3, TypeDesc::FLOAT);
        image_.reset(spec, OIIO::InitializePixels::No);  // (filled next, in bands)
        const float background[3] = {0.13f, 0.13f, 0.14f};
        // In bands, a cancel asked between them (a sheet of 1024^2 panels
        // is 85 MB of floats: 167 ms at once here).
        for (int y = 0; y < spec.height; y += kBand) {
            host::stop_if_cancelled();
            if (!IBA::fill(image_, background, OIIO::ROI(0, spec.width, y, std::min(y + kBand, spec.height))))
                throw std::runtime_error("cannot compose the sheet: " + image_.geterror());
        }
    }

    // The sheet as `dst` in `spec`'s format, in bands of rows as above.
    void deliver(ImageBuf& dst, const ImageSpec& spec) const
    {
        // (Every row is set below; dst gets the sheet only when all are:
        // a cancel part way leaves no uninitialised rows behind.)
        ImageBuf out(spec, OIIO::InitializePixels::No);
        const int w = image_.spec().width, h = image_.spec().height;
        std::vector<float> band(std::size_t(w) * 3 * std::size_t(kBand));
        for (int y = 0; y < h; y += kBand) {
            host::stop_if_cancelled();
            const OIIO::ROI rows(0, w, y, std::min(y + kBand, h), 0, 1, 0, 3);
            if (!image_.get_pixels(rows, TypeDesc::FLOAT, band.data()) ||
                !out.set_pixels(rows, TypeDesc::FLOAT, band.data()))
                throw std::runtime_error("cannot compose the sheet: " + out.geterror());
        }
        dst.swap(out);
    }

    // Cell (col, row)'s top-left corner.
    int x(int col) const { return kMargin + col * (cw_ + kMargin); }
    int y(int row) const { return kMargin + row * (kCaption + ch_ + kBar + kMargin); }

    void panel(int col, int row, const std::string& caption, const ImageBuf& pixels)
    {
        host::stop_if_cancelled();  // (between the panel's resizing and its paste)
        text(x(col), y(row) + kCaption - 10, caption, kFontSize);
        ImageBuf& dst = image_;
        if (!IBA::paste(dst, x(col), y(row) + kCaption, 0, 0, pixels))
            throw std::runtime_error("cannot compose the sheet: " + dst.geterror());
    }

    // A colour bar under cell (col, row) from lo to hi, with five labels.
    void bar(int col, int row, const std::vector<Rgb>& stops, double lo, double hi, const std::string& unit)
    {
        const int top = y(row) + kCaption + ph_ + 8, height = 14;
        // As wide as the cell: a panel a few texels wide still gets a
        // readable scale.
        for (int i = 0; i < cw_; ++i) {
            const Rgb c = ramp(stops, double(i) / std::max(1, cw_ - 1));
            const float v[3] = {c.r, c.g, c.b};
            for (int j = 0; j < height; ++j)
                image_.setpixel(x(col) + i, top + j, v);
        }
        for (int k = 0; k <= 4; ++k) {
            const double value = lo + (hi - lo) * k / 4.0;
            char label[48];
            std::snprintf(label, sizeof label, "%.3g%s", value, k == 4 ? (" " + unit).c_str() : "");
            const int px = x(col) + int(std::lround((cw_ - 1) * k / 4.0));
            text(px, top + height + 18, label, 14,
                 k == 0   ? OIIO::ImageBufAlgo::TextAlignX::Left
                 : k == 4 ? OIIO::ImageBufAlgo::TextAlignX::Right
                          : OIIO::ImageBufAlgo::TextAlignX::Center);
        }
    }

    void text(int px, int py, const std::string& s, int size,
              OIIO::ImageBufAlgo::TextAlignX align = OIIO::ImageBufAlgo::TextAlignX::Left)
    {
        const float white[3] = {0.92f, 0.92f, 0.92f};
        if (!IBA::render_text(image_, px, py, s, size, kFont, white, align))
            throw std::runtime_error("cannot draw the captions (" + image_.geterror() + "); the font " +
                                     kFont + " comes with Debian's fonts-dejavu-core");
    }

    ImageBuf& image() { return image_; }

private:
    static constexpr int kBand = 64;  // rows (2.4 MB of a 1024^2 sheet's floats)
    int ph_, cw_, ch_;
    ImageBuf image_;
};

}  // namespace

SphericalHarmonics environment_harmonics(const ImageBuf& latlong)
{
    const int w = latlong.spec().width, h = latlong.spec().height, nch = latlong.nchannels();
    if (w < 2 || h < 1)
        throw std::runtime_error("the environment is too small for a lat-long image");
    std::vector<float> px(std::size_t(w) * h * nch), rgb(std::size_t(w) * h * 3);
    if (!latlong.get_pixels(latlong.roi(), TypeDesc::FLOAT, px.data()))
        throw std::runtime_error("cannot read the environment's pixels: " + latlong.geterror());
    for (std::size_t i = 0; i < std::size_t(w) * h; ++i)
        for (int c = 0; c < 3; ++c) {
            const float v = px[i * nch + std::size_t(std::min(c, nch - 1))];
            if (!std::isfinite(v) || v < 0.0f)
                throw std::runtime_error("the environment has a negative, NaN or infinite value");
            rgb[3 * i + c] = v;
        }
    const TypeDesc stored = latlong.nativespec().format;
    if (stored.basetype == TypeDesc::UINT8 || stored.basetype == TypeDesc::UINT16)
        detail::to_linear(rgb, 3, "sRGB");
    return project(rgb, w, h);
}

SphericalHarmonics sky_harmonics()
{
    // A clear sky: blue at the zenith, pale at the horizon, a dim brown ground.
    const int w = 128, h = 64;
    std::vector<float> rgb(std::size_t(w) * h * 3);
    for (int j = 0; j < h; ++j) {
        const double z = std::cos(M_PI * (j + 0.5) / h);
        const Rgb c =
            z >= 0 ? ramp({{0.80f, 0.86f, 0.95f}, {0.45f, 0.60f, 0.90f}, {0.25f, 0.42f, 0.85f}}, std::sqrt(z))
                   : Rgb{0.20f, 0.17f, 0.14f};
        for (int i = 0; i < w; ++i) {
            float* p = &rgb[3 * (std::size_t(j) * w + i)];
            p[0] = c.r;
            p[1] = c.g;
            p[2] = c.b;
        }
    }
    return project(rgb, w, h);
}

void irradiance(const SphericalHarmonics& sh, const float n[3], float rgb[3])
{
    const double c1 = 0.429043, c2 = 0.511664, c3 = 0.743125, c4 = 0.886227, c5 = 0.247708;
    const double x = n[0], y = n[1], z = n[2];
    for (int c = 0; c < 3; ++c) {
        auto L = [&](int k) { return double(sh.c[k][c]); };
        rgb[c] = float(c1 * L(8) * (x * x - y * y) + c3 * L(6) * z * z + c4 * L(0) - c5 * L(6) +
                       2 * c1 * (L(4) * x * y + L(7) * x * z + L(5) * y * z) +
                       2 * c2 * (L(3) * x + L(1) * y + L(2) * z));
    }
}

ImageBuf preview(const ImageBuf& normals, const ImageBuf& height, const PreviewOptions& options)
{
    return detail::first_form([&](ImageBuf& dst) { preview(dst, normals, height, options); });
}

bool preview(ImageBuf& dst, const ImageBuf& normals, const ImageBuf& height, const PreviewOptions& o)
{
    return detail::guarded(dst, "preview", o.exec, o, [&] {
        const ROI roi = detail::resolve_roi(normals, {});
        const ROI hroi = detail::resolve_roi(height, {});
        const int w = roi.width(), ht = roi.height();
        if (hroi.width() != w || hroi.height() != ht)
            throw std::runtime_error("the normal map is " + std::to_string(w) + "x" + std::to_string(ht) +
                                     ", the height " + std::to_string(hroi.width()) + "x" +
                                     std::to_string(hroi.height()) +
                                     "; give the height made from these normals");
        // The sheet is host work between few kernels: progress by pass, a
        // cancel asked within each (the passes took 1.2 s at 1024^2 here).
        const std::function<void(double)> progress = detail::marked(o.exec.on_progress);
        const auto step = [&](double done) {
            host::stop_if_cancelled();
            if (progress)
                progress(done);
        };
        const std::vector<float> h = detail::height_channel(height, hroi, o.exec, "preview");
        const detail::Wrap wrap = detail::height_wrap(height, h, w, ht, o.boundary, o.exec, "preview");
        const SphericalHarmonics sh = o.env.empty() ? sky_harmonics() : [&] {
            ImageBuf env;
            if (!read_image(env, o.env))
                throw std::runtime_error("env: " + relief::geterror());
            return environment_harmonics(env);
        }();

        // The device: the input's slopes (decoded and clamped as --height
        // does), the height's normals, the round trip.
        const detail::DerivedSlopes d = detail::derive_slopes(normals, roi, o.normals, o.exec);
        const std::size_t n = std::size_t(w) * ht;
        std::vector<float> g(2 * n), nh(3 * n);
        host::read_slopes(*d.context, d.slopes, g.data());
        host::height_normals(*d.context, h.data(), w, ht, wrap.x, wrap.y, 1.0f, true, nh.data());
        const host::RoundTrip trip = host::round_trip(*d.context, d.slopes, h.data(), wrap.x, wrap.y, true);
        step(0.3);

        // Lighting: white key light plus the environment's diffuse light,
        // normalised so that an upward surface receives 1 from it.
        const double az = o.azimuth * M_PI / 180.0, el = o.elevation * M_PI / 180.0;
        const float light[3] = {float(std::cos(el) * std::cos(az)), float(-std::cos(el) * std::sin(az)),
                                float(std::sin(el))};
        const float up[3] = {0.0f, 0.0f, 1.0f};
        float e_up[3];
        irradiance(sh, up, e_up);
        const float norm = 1.0f / std::max(1e-6f, 0.2126f * e_up[0] + 0.7152f * e_up[1] + 0.0722f * e_up[2]);
        auto shade = [&](const float nv[3], float* out) {
            float e[3];
            irradiance(sh, nv, e);
            const float key = std::max(0.0f, nv[0] * light[0] + nv[1] * light[1] + nv[2] * light[2]);
            for (int c = 0; c < 3; ++c)
                out[c] = std::min(1.0f, 0.75f * (0.85f * key + 0.3f * norm * std::max(0.0f, e[c])));
        };
        // (Each picture is made when its pass starts: zeroing all five at
        // once, 60 MB at 1024^2, kept a host from hearing progress.)
        std::vector<float> lit_in(3 * n), lit_h(3 * n);
        for (std::size_t i = 0; i < n; ++i) {
            host::stop_if_cancelled_every(i);
            const float gx = g[2 * i], gy = g[2 * i + 1];
            const float len = std::sqrt(gx * gx + gy * gy + 1.0f);
            const float nin[3] = {-gx / len, -gy / len, 1.0f / len};
            shade(nin, &lit_in[3 * i]);
            shade(&nh[3 * i], &lit_h[3 * i]);
        }
        detail::from_linear(lit_in, 3, "sRGB");
        detail::from_linear(lit_h, 3, "sRGB");
        step(0.55);

        // Emboss: the height one texel toward the light minus the height.
        const double lx = std::cos(az), ly = -std::sin(az);
        auto at = [&](int i, int j) {
            i = wrap.x ? (i % w + w) % w : std::clamp(i, 0, w - 1);
            j = wrap.y ? (j % ht + ht) % ht : std::clamp(j, 0, ht - 1);
            return double(h[std::size_t(j) * w + i]);
        };
        std::vector<float> diff(n);
        for (int j = 0; j < ht; ++j)
            for (int i = 0; i < w; ++i) {
                host::stop_if_cancelled_every(std::size_t(j) * std::size_t(w) + std::size_t(i));
                const double x = i + lx, y = j + ly;
                const int i0 = int(std::floor(x)), j0 = int(std::floor(y));
                const double fx = x - i0, fy = y - j0;
                const double s = (1 - fy) * ((1 - fx) * at(i0, j0) + fx * at(i0 + 1, j0)) +
                                 fy * ((1 - fx) * at(i0, j0 + 1) + fx * at(i0 + 1, j0 + 1));
                diff[std::size_t(j) * w + i] = float(s - at(i, j));
            }
        std::vector<float> mag(n);
        for (std::size_t i = 0; i < n; ++i)
            mag[i] = std::abs(diff[i]);
        host::stop_if_cancelled();
        const double k = std::max(1e-9, quantile(mag, 0.99));
        host::stop_if_cancelled();
        std::vector<float> emboss(3 * n);
        for (std::size_t i = 0; i < n; ++i)
            emboss[3 * i] = emboss[3 * i + 1] = emboss[3 * i + 2] =
                float(std::clamp(0.5 + 0.5 * diff[i] / k, 0.0, 1.0));

        step(0.7);
        // Angular error: 0 to a round bound at or above its 99th percentile.
        const double p99 = quantile(trip.angle_deg, 0.99);
        host::stop_if_cancelled();
        double top = 90.0;
        for (double b : {0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 30.0, 45.0, 90.0})
            if (b >= p99) {
                top = b;
                break;
            }
        const auto [lo_it, hi_it] = std::minmax_element(h.begin(), h.end());
        const double lo = *lo_it, hi = *hi_it;
        host::stop_if_cancelled();
        std::vector<float> heat(3 * n), relief_map(3 * n);
        for (std::size_t i = 0; i < n; ++i) {
            host::stop_if_cancelled_every(i);
            const Rgb a = ramp(kHeat, trip.angle_deg[i] / top);
            const Rgb b = ramp(kViridis, hi > lo ? (h[i] - lo) / (hi - lo) : 0.5);
            heat[3 * i] = a.r;
            heat[3 * i + 1] = a.g;
            heat[3 * i + 2] = a.b;
            relief_map[3 * i] = b.r;
            relief_map[3 * i + 1] = b.g;
            relief_map[3 * i + 2] = b.b;
        }

        // Panels at the map's resolution, from 344 to 1024 texels wide.
        double s = std::min({1.0, 1024.0 / w, 1024.0 / ht});
        if (w * s < 344.0)
            s = std::min(344.0 / w, 2048.0 / ht);
        const int pw = std::max(1, int(std::lround(w * s))), ph = std::max(1, int(std::lround(ht * s)));
        step(0.8);
        Sheet sheet(pw, ph);
        const char* convention = detail::convention_name(d.stats.chosen);
        sheet.panel(0, 0, std::string("a  input normals, lit (") + convention + ")",
                    fit(lit_in, w, ht, pw, ph));
        step(0.84);
        sheet.panel(1, 0, "b  the height's normals, lit", fit(lit_h, w, ht, pw, ph));
        step(0.88);
        sheet.panel(2, 0, "c  emboss: height toward the light - height", fit(emboss, w, ht, pw, ph));
        step(0.92);
        sheet.panel(0, 1, "d  angular error between a and b", fit(heat, w, ht, pw, ph));
        sheet.bar(0, 1, kHeat, 0.0, top, "deg");
        step(0.96);
        sheet.panel(1, 1, "e  height", fit(relief_map, w, ht, pw, ph));
        sheet.bar(1, 1, kViridis, lo, hi, "texels");
        host::stop_if_cancelled();
        const int tx = sheet.x(2), ty = sheet.y(1) + kCaption;
        const std::vector<std::string> lines = {
            "relief preview, " + std::to_string(w) + "x" + std::to_string(ht) + " texels",
            "light: azimuth " + detail::format_double("%g", o.azimuth) + ", elevation " +
                detail::format_double("%g", o.elevation) + " deg",
            std::string("environment: ") + (o.env.empty() ? "procedural sky" : o.env),
            std::string("normals: ") + convention + "; boundary " + detail::wrap_name(wrap),
            "round trip, angular error (deg):",
            "  mean " + detail::format_double("%.3g", trip.mean_deg) + ", p95 " +
                detail::format_double("%.3g", trip.p95_deg) + ", max " +
                detail::format_double("%.3g", trip.max_deg),
            "residual share " + detail::format_double("%.3g", trip.residual_share),
        };
        for (std::size_t i = 0; i < lines.size(); ++i)
            sheet.text(tx, ty + 24 * int(i), lines[i], 16);

        ImageSpec spec = sheet.image().spec();
        spec.set_format(TypeDesc::UINT8);
        spec.attribute("relief:native_format", "uint8");
        spec.attribute("oiio:ColorSpace", "sRGB");
        sheet.deliver(dst, spec);
        detail::say(o.exec, Severity::Info,
                    "preview: " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                        " sheet, panels " + std::to_string(pw) + "x" + std::to_string(ph));
        return true;
    });
}

}  // namespace relief
