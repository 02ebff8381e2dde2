// SPDX-License-Identifier: Apache-2.0
// The operation table's entries for --correct and --bake: each operation's slots,
// modifiers (what users see, how they set the option structs) and run.
#include "schema.h"

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "relief/bake.h"
#include "relief/correct.h"
#include "relief/validate.h"

namespace relief::table {

Operation correct_operation()
{
    Operation op;
    op.info = {"correct",
               "height map -> distortion-correcting offsets (2 channels du, dv in texture units: "
               "the surface point at u shows the texture at u + offset)",
               {{"height", 1, 4096, "displacement; channel 0 is used"}},
               {{"offsets", 2, 2, "du, dv in texture units (1 = the width, height)"}},
               {},
               "correct"};
    auto k = [](auto& c) -> auto&
    {
        return c.correct;
    };
    op.modifiers = {
        number(
            detail::limits::displacement_scale, [k](auto& c) -> auto& { return k(c).scale; }, "S", "",
            "world height = S x stored height, the texture's width = 1 world unit (auto: "
            "1/width for relief's own heights, in texels)"),
        number(
            detail::limits::theta, [k](auto& c) -> auto& { return k(c).theta; }, "T", "",
            "area exponent (higher: keep areas)"),
        choice(
            "nodes", [k](auto& c) -> auto& { return k(c).nodes; },
            std::vector<std::pair<std::string, CorrectNodes>>{{"corner", CorrectNodes::Corner},
                                                              {"center", CorrectNodes::Center}},
            "", "mesh nodes at texel corners or centres"),
        choice(
            "boundary", [k](auto& c) -> auto& { return k(c).boundary; },
            std::vector<std::pair<std::string, CorrectBoundaries>>{
                {"auto", CorrectBoundary::Auto},
                {"periodic", CorrectBoundary::Periodic},
                {"fixed", CorrectBoundary::Fixed},
                {"periodic,fixed", {CorrectBoundary::Periodic, CorrectBoundary::Fixed}},
                {"fixed,periodic", {CorrectBoundary::Fixed, CorrectBoundary::Periodic}}},
            "",
            "periodic: the texture tiles; fixed: the border stays; X,Y: x's and y's "
            "(periodic,fixed: tiles along x only); auto: each axis periodic when the height is "
            "continuous across its wrap seam"),
        [k] {
            Modifier m;
            m.info.name = "fix";
            m.info.type = ModifierType::File;
            m.info.choices = {"height:H0:DH", "none"};  // none: the default, as written out
            m.info.placeholder = "FILE";
            m.info.meaning = "keep texels with weight w within 1/w texels: w from channel 0 of "
                             "FILE, or max(0, 1-|h-H0|/DH)";
            m.set = [k](OperationCall& c, const std::string& v, double) {
                if (v.rfind("height:", 0) != 0) {
                    c.fix_file = v == "none" ? std::string() : v;
                    return;
                }
                // The written form; the values' rule is validate()'s (a width
                // of 0 would read as no tent, so it is refused here).
                const std::size_t a1 = v.find(':'), a2 = v.find(':', a1 + 1);
                double h0 = 0.0, dh = 0.0;
                if (a2 == std::string::npos || !read_number(v.substr(a1 + 1, a2 - a1 - 1), h0) ||
                    !read_number(v.substr(a2 + 1), dh) || !(float(dh) > 0.0f))
                    throw std::invalid_argument(
                        "fix=" + v + ": write fix=height:H0:DH (stored height H0, tent half-width DH > 0)");
                k(c).fix_height = float(h0);
                k(c).fix_width = float(dh);
            };
            m.path = [](const OperationCall& c) { return c.fix_file; };
            m.get = [k](const OperationCall& c) {
                if (k(c).fix_width > 0.0f)
                    return "height:" + number_text(k(c).fix_height) + ":" + number_text(k(c).fix_width);
                return !c.fix_file.empty() ? c.fix_file
                       : k(c).fix_mask     ? std::string("image")
                                           : std::string("none");
            };
            return m;
        }(),
        number(
            detail::limits::iterations, [k](auto& c) -> auto& { return k(c).iterations; }, "N", "",
            "per coarse-to-fine level (auto: until the tolerance)"),
        number(
            detail::limits::tolerance, [k](auto& c) -> auto& { return k(c).tolerance; }, "TOL", "",
            "relative energy change per pass over the nodes (a global step is one) at which iterations=auto "
            "stops (the finest level also once the next is predicted below it)"),
        number(
            detail::limits::levels, [k](auto& c) -> auto& { return k(c).levels; }, "N", "",
            "coarse-to-fine levels (1 = single resolution; auto: down to 16 texels)"),
        number(
            detail::limits::threshold, [k](auto& c) -> auto& { return k(c).threshold; }, "E", "",
            "correct nothing when no triangle's anisotropy or area change exceeds this"),
        choice(
            "skip", [k](auto& c) -> auto& { return k(c).skip_tiles; }, kOnOff, "",
            "skip tiles whose nodes cannot move (the result is identical)"),
        choice(
            "search", [k](auto& c) -> auto& { return k(c).search; },
            std::vector<std::pair<std::string, CorrectSearch>>{{"brent", CorrectSearch::Brent},
                                                               {"golden", CorrectSearch::Golden},
                                                               {"ternary", CorrectSearch::Ternary}},
            "",
            "line search per node: Brent's (parabolic, precise relative to the step), golden "
            "section or ternary (the first implementation)"),
        number(
            detail::limits::relax, [k](auto& c) -> auto& { return k(c).relax; }, "W", "",
            "over-relaxation: move W x the searched step when that lowers the energy too "
            "(1 = plain steps)"),
        choice(
            "hats", [k](auto& c) -> auto& { return k(c).hats; },
            std::vector<std::pair<std::string, CorrectHats>>{
                {"auto", CorrectHats::Auto}, {"off", CorrectHats::Off}, {"always", CorrectHats::Always}},
            "",
            "hat moves (regions of nodes under bilinear hats of every scale move together): auto "
            "where the nodes alone converge slowly (cliffs), always (every iteration) or off (global "
            "steps do their work for less); off under fix"),
        choice(
            "global", [k](auto& c) -> auto& { return k(c).global; },
            std::vector<std::pair<std::string, CorrectGlobal>>{{"auto", CorrectGlobal::Auto},
                                                               {"off", CorrectGlobal::Off},
                                                               {"always", CorrectGlobal::Always}},
            "",
            "global steps (every node at once along the gradient summed over hats of every scale, the "
            "step searched on the total energy): auto after each iteration while they pay, always or "
            "off; off under fix"),
        number(
            detail::limits::polish, [k](auto& c) -> auto& { return k(c).polish; }, "N", "",
            "nodes=corner: N iterations on the delivered mesh after the solve (texel centres from the "
            "means of their corners, each move lowering its energy; 0: the corner means)"),
    };
    op.validate = [](const OperationCall& c) {
        CorrectOptions o = c.correct;
        if (!c.fix_file.empty() && !o.fix_mask)
            o.fix_mask = &file_to_come();
        return relief::validate(o);
    };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        CorrectOptions o = c.correct;
        ImageBuf fix;
        o.fix_mask = file_image(o.fix_mask, c.fix_file, "fix", fix);
        CorrectReport report;
        if (c.report_json && !o.report)
            o.report = &report;
        if (!relief::correct(dst, *in[0], o))
            return false;
        if (c.report_json)
            *c.report_json = o.report->to_json();
        return true;
    };
    return op;
}

Operation bake_operation()
{
    Operation op;
    op.info = {"bake",
               "texture and offset map -> the texture resampled at u + offset(u)",
               {{"texture", 1, 4096, "colour, normal or data map"},
                {"offsets", 2, 4096, "relief's correct output (du, dv in texture units)"}},
               {{"texture", 1, 4096, "the texture's channels, corrected"}},
               {},
               ""};
    auto b = [](auto& c) -> auto&
    {
        return c.bake;
    };
    op.modifiers = {
        choice(
            "filter", [b](auto& c) -> auto& { return b(c).filter; },
            std::vector<std::pair<std::string, BakeFilter>>{{"bilinear", BakeFilter::Bilinear},
                                                            {"bicubic", BakeFilter::Bicubic}},
            "", "resampling filter (bicubic = Catmull-Rom)"),
        choice(
            "colorspace", [b](auto& c) -> auto& { return b(c).colorspace; },
            std::vector<std::pair<std::string, BakeColorspace>>{{"auto", BakeColorspace::Auto},
                                                                {"sRGB", BakeColorspace::SRGB},
                                                                {"srgb", BakeColorspace::SRGB},
                                                                {"linear", BakeColorspace::Linear},
                                                                {"raw", BakeColorspace::Raw}},
            "",
            "colour is filtered in linear light via OpenColorIO ($OCIO, else the sRGB curve); "
            "auto: the file's declared space, 8-bit PNG/JPEG as sRGB; raw: no conversion"),
        choice(
            "kind", [b](auto& c) -> auto& { return b(c).kind; },
            std::vector<std::pair<std::string, BakeKind>>{{"auto", BakeKind::Auto},
                                                          {"color", BakeKind::Color},
                                                          {"normal", BakeKind::Normal},
                                                          {"data", BakeKind::Data},
                                                          {"height", BakeKind::Height}},
            "", "normal maps bake as data and are renormalised; height maps are refused"),
        choice(
            "wrap", [b](auto& c) -> auto& { return b(c).wrap; },
            std::vector<std::pair<std::string, BakeWrap>>{
                {"auto", BakeWrap::Auto}, {"periodic", BakeWrap::Periodic}, {"clamp", BakeWrap::Clamp}},
            "", "auto: per axis, periodic where the offsets were computed with a periodic boundary"),
    };
    op.validate = [](const OperationCall& c) { return relief::validate(c.bake); };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::bake(dst, *in[0], *in[1], c.bake);
    };
    return op;
}

}  // namespace relief::table
