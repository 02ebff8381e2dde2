// SPDX-License-Identifier: Apache-2.0
// The operation table's entries for --slopes and --height: each operation's slots,
// modifiers (what users see, how they set the option structs) and run.
#include "schema.h"

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "operations/height_memory.h"
#include "relief/height.h"
#include "relief/slopes.h"
#include "relief/udim.h"
#include "relief/validate.h"

namespace relief::table {

namespace {

// An operation of one normal map, `result` its output, with the modifiers
// that decode the map (`decoding`: where the call keeps them).
template <class F>
Operation normal_map_operation(const char* name, const char* summary, ImageSlot result, const char* report,
                               F decoding)
{
    Operation op;
    op.info = {name, summary, {kNormals}, {std::move(result)}, {}, report};
    op.modifiers = decoding_modifiers(decoding);
    return op;
}

}  // namespace

Operation slopes_operation()
{
    Operation op = normal_map_operation(
        "slopes",
        "normal map -> slopes (2 channels gx, gy: height change per texel step along x and y, in texels)",
        {"slopes", 2, 2, "gx, gy in texels per texel"}, "",
        [](auto& c) -> auto& { return c.slopes.normals; });
    op.validate = [](const OperationCall& c) { return relief::validate(c.slopes); };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::slopes(dst, *in[0], c.slopes);
    };
    return op;
}

Operation height_operation()
{
    auto h = [](auto& c) -> auto&
    {
        return c.height;
    };
    Operation op = normal_map_operation(
        "height",
        "normal map -> displacement (1 channel, texel units: 1.0 = one texel's "
        "width; bumps positive, zero mean)",
        {"height", 1, 1, "height in texels"}, "height", [h](auto& c) -> auto& { return h(c).normals; });
    const char* rays = "method=rays";
    const char* poisson = "method=poisson";
    std::vector<Modifier> more = {
        choice(
            "method", [h](auto& c) -> auto& { return h(c).method; },
            std::vector<std::pair<std::string, HeightMethod>>{{"auto", HeightMethod::Auto},
                                                              {"poisson", HeightMethod::Poisson},
                                                              {"rays", HeightMethod::Rays}},
            "",
            "poisson: least squares (Frankot-Chellappa); rays: radial ray integration; "
            "auto: poisson, or rays when a ray modifier is given"),
        [h] {
            std::vector<std::pair<std::string, Boundaries>> words = kBoundaryWords;
            words.insert(words.begin() + 3, {"clip", Boundary::Free});  // (after "free": free is written)
            Modifier m = choice(
                "boundary", [h](auto& c) -> auto& { return h(c).boundary; }, words, "",
                "periodic: the texture tiles; free (clip for rays): it does not; X,Y: x's and y's, "
                "for poisson (periodic,free: tiles along x only); auto: each axis periodic when the "
                "surface continues across its wrap seam (slopes, then block heights; rays: when both do)");
            // Written as each method takes it: rays refuse "free".
            m.get = [h, get = m.get](const OperationCall& c) {
                const std::string name = get(c);
                return name == "free" && h(c).method == HeightMethod::Rays ? std::string("clip") : name;
            };
            return m;
        }(),
        choice(
            "udim", [h](auto& c) -> auto& { return h(c).udim; },
            std::vector<std::pair<std::string, UdimMode>>{
                {"auto", UdimMode::Auto}, {"joint", UdimMode::Joint}, {"each", UdimMode::Each}},
            "",
            "over a <UDIM> set: joint: the tiles as one surface (missing tiles weighted 0); each: "
            "every tile alone; auto: tiles joined where the slopes continue across their edge"),
        number(
            detail::limits::highpass, [h](auto& c) -> auto& { return h(c).highpass; }, "R", poisson,
            "relief balance: remove structure larger than R texels (0 = off)"),
        [h] {
            Modifier m;
            m.info.name = "mask";
            m.info.type = ModifierType::File;
            // "none", the default, is what modifier_text writes for no mask:
            // the call written out in full must parse back to itself.
            m.info.choices = {"alpha", "none"};
            m.info.placeholder = "FILE";
            m.info.applies_to = "method=poisson";
            m.info.meaning = "per-texel weights in [0,1] (channel 0 of FILE, or the normal "
                             "map's alpha); 0 excludes a texel's slopes";
            m.set = [h](OperationCall& c, const std::string& text, double) {
                h(c).mask_alpha = text == "alpha";
                c.mask_file = text == "alpha" || text == "none" ? std::string() : text;
            };
            m.path = [](const OperationCall& c) { return c.mask_file; };
            m.get = [h](const OperationCall& c) {
                return h(c).mask_alpha        ? std::string("alpha")
                       : !c.mask_file.empty() ? c.mask_file
                       : h(c).mask            ? std::string("image")
                                              : std::string("none");
            };
            return m;
        }(),
        choice(
            "impl", [h](auto& c) -> auto& { return h(c).impl; },
            std::vector<std::pair<std::string, RayImpl>>{{"fast", RayImpl::Fast},
                                                         {"reference", RayImpl::Reference}},
            rays, "fast: cost independent of the radius; reference: walks every ray"),
        number(
            detail::limits::rays, [h](auto& c) -> auto& { return h(c).rays; }, "J", rays,
            "ray directions per texel"),
        number(
            detail::limits::radius, [h](auto& c) -> auto& { return h(c).radius; }, "R", rays, "ray length"),
        number(
            detail::limits::phase, [h](auto& c) -> auto& { return h(c).phase; }, "PHI", rays,
            "ray angles are 2 pi (j + PHI) / J"),
        choice(
            "directions", [h](auto& c) -> auto& { return h(c).directions; },
            std::vector<std::pair<std::string, RayDirections>>{{"rational", RayDirections::Rational},
                                                               {"exact", RayDirections::Exact}},
            rays, "rational: integer steps nearest the angles; exact: the angles (impl=reference)"),
        choice(
            "skip", [h](auto& c) -> auto& { return h(c).skip_flat; }, kOnOff, rays,
            "skip tiles whose rays meet only zero slopes (the result is identical)"),
    };
    op.modifiers.insert(op.modifiers.end(), more.begin(), more.end());
    op.finish = [](OperationCall& c, const std::map<std::string, std::string>& given,
                   const std::vector<Modifier>& modifiers) {
        HeightOptions& o = c.height;
        // Whether a ray modifier was written, whatever its value: it picks the
        // method, and poisson refuses it (the values alone cannot tell).
        bool ray_option = false;
        std::vector<std::string> ray_names;
        for (const Modifier& m : modifiers)
            if (m.info.applies_to == "method=rays") {
                ray_names.push_back(m.info.name);
                ray_option |= given.count(m.info.name) > 0;
            }
        if (o.method == HeightMethod::Auto && ray_option)
            o.method = HeightMethod::Rays;
        if (o.method == HeightMethod::Poisson && ray_option)
            throw std::invalid_argument(listed(ray_names) + " apply to method=rays");
        const auto b = given.find("boundary");
        const std::string boundary = b == given.end() ? "auto" : b->second;
        if (o.method == HeightMethod::Rays && boundary == "free")
            throw std::invalid_argument("rays take boundary=periodic, clip or auto");
        if (o.method != HeightMethod::Rays && boundary == "clip")
            throw std::invalid_argument("method=poisson takes boundary=periodic, free, auto or one per axis "
                                        "(periodic,free)");
    };
    op.validate = [](const OperationCall& c) {
        HeightOptions o = c.height;
        if (!c.mask_file.empty() && !o.mask)
            o.mask = &file_to_come();
        return relief::validate(o);
    };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        HeightOptions o = c.height;
        ImageBuf mask;
        o.mask = file_image(o.mask, c.mask_file, "mask", mask);
        HeightReport report;
        if (c.report_json && !o.report)
            o.report = &report;
        if (!relief::height(dst, *in[0], o))
            return false;
        if (c.report_json)
            *c.report_json = o.report->to_json();
        return true;
    };
    op.check_memory = [](const OperationCall& c, int w, int h) {
        HeightOptions o = c.height;
        if (!c.mask_file.empty() && !o.mask)
            o.mask = &file_to_come();
        detail::check_height_memory(o, w, h, 0);
    };
    op.joins_tiles = [](const OperationCall& c) {
        return c.height.udim == UdimMode::Joint ||
               (c.height.udim == UdimMode::Auto && !c.height.mask && c.mask_file.empty());
    };
    op.run_tiles = [](std::vector<ImageBuf>& dst, const OperationCall& c, const std::vector<int>& numbers,
                      const std::vector<const ImageBuf*>& in) {
        std::vector<UdimTile> tiles;
        for (std::size_t i = 0; i < in.size(); ++i)
            tiles.push_back({numbers[i], in[i]});
        HeightOptions o = c.height;
        ImageBuf mask;
        o.mask = file_image(o.mask, c.mask_file, "mask", mask);
        HeightReport report;
        if (c.report_json && !o.report)
            o.report = &report;
        if (!relief::height_udim(dst, tiles, o))
            return false;
        if (c.report_json)
            *c.report_json = o.report->to_json();
        return true;
    };
    // Poisson's device, kernels and FFT plans depend on the size only.
    op.sets_up_ahead = [](const OperationCall& c) { return c.height.method != HeightMethod::Rays; };
    op.describe = [](const OperationCall& c) { return relief::describe(c.height); };
    return op;
}

}  // namespace relief::table
