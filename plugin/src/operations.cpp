// The operation table (relief/operations.h): each operation and its
// modifiers, once. A modifier's entry says what it is (type, range or
// choices, meaning) and how it reads and writes the option structs; its
// default is what the option struct holds when default-constructed, so the
// structs' initialisers are the only place a default is written.
#include "relief/operations.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "binary_cache.h"
#include "error_state.h"
#include "kernel_sources.h"
#include "operation_table.h"
#include "relief/errors.h"
#include "relief/imageio.h"
#include "relief/version.h"

namespace relief {

using OIIO::ImageBuf;

namespace {

namespace fs = std::filesystem;

// A modifier as the table holds it: what users see, and how it reads and
// writes an OperationCall.
struct Modifier {
    ModifierInfo info;
    // Applies a value already checked against `info` (`number` is its
    // numeric value for Integer/Number types, else 0).
    std::function<void(OperationCall&, const std::string& text, double number)> set;
    // The value `call` holds, as the command line writes it.
    std::function<std::string(const OperationCall&)> get;
};

struct Operation {
    OperationInfo info;
    std::vector<Modifier> modifiers;
    // Checks combinations once every given modifier is set (`given`: key -> text).
    std::function<void(OperationCall&, const std::map<std::string, std::string>& given,
                       const std::vector<Modifier>& modifiers)>
        finish;
    std::function<bool(ImageBuf&, const OperationCall&, const std::vector<const ImageBuf*>&)> run;
};

// Integers as integers (1000000, not 1e+06); else the shortest text that
// reads back as the same float.
std::string number_text(double v)
{
    char buf[40];
    if (v == std::floor(v) && std::fabs(v) < 1e7) {
        std::snprintf(buf, sizeof buf, "%.0f", v);
        return buf;
    }
    for (int digits = 6; digits <= 17; ++digits) {  // %g's own 6 first: "0.5", not "5e-01"
        std::snprintf(buf, sizeof buf, "%.*g", digits, v);
        if (float(std::strtod(buf, nullptr)) == float(v))
            break;
    }
    return buf;
}

bool in_range(const ModifierInfo& m, double v)
{
    return (m.min_open ? v > m.min : v >= m.min) && (m.max_open ? v < m.max : v <= m.max);
}

std::string joined(const std::vector<std::string>& v, const char* sep)
{
    std::string s;
    for (const auto& x : v)
        s += (s.empty() ? "" : sep) + x;
    return s;
}

// "a, b and c"
std::string listed(const std::vector<std::string>& names)
{
    std::string s;
    for (std::size_t i = 0; i < names.size(); ++i)
        s += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
    return s;
}

// A file modifier's word with arguments ("height:H0:DH"): the prefix it starts with.
std::string word_prefix(const std::string& word)
{
    const std::size_t colon = word.find(':');
    return colon == std::string::npos ? std::string() : word.substr(0, colon + 1);
}

// Checks `text` against m; returns its number (Integer/Number), else 0.
double check_value(const ModifierInfo& m, const std::string& text)
{
    const std::string kv = m.name + "=" + text;
    for (const auto& w : m.choices)
        if (text == w)
            return 0.0;
    switch (m.type) {
    case ModifierType::Choice:
        throw std::invalid_argument(kv + " is not one of " + joined(m.choices, "|"));
    case ModifierType::Integer: {
        long long v = 0;
        const char* end = text.data() + text.size();
        auto r = std::from_chars(text.data(), end, v);
        if (text.empty() || r.ec != std::errc() || r.ptr != end || v < m.min || v > m.max)
            throw std::invalid_argument(kv + " must be an integer in " + range_text(m) +
                                        (m.choices.empty() ? "" : " or " + joined(m.choices, "|")));
        return double(v);
    }
    case ModifierType::Number: {
        double v = 0.0;
        const char* end = text.data() + text.size();
        auto r = std::from_chars(text.data(), end, v);
        if (text.empty() || r.ec != std::errc() || r.ptr != end || !std::isfinite(v))
            throw std::invalid_argument(kv + " is not a number");
        if (!in_range(m, v))
            throw std::invalid_argument(kv + " is out of range; it must be in " + range_text(m) +
                                        (m.choices.empty() ? "" : " or " + joined(m.choices, "|")));
        return v;
    }
    case ModifierType::Output:
    case ModifierType::Text:
        return 0.0;  // checked by the modifier's set()
    case ModifierType::File: {
        for (const auto& w : m.choices) {
            const std::string p = word_prefix(w);
            if (!p.empty() && text.compare(0, p.size(), p) == 0)
                return 0.0;  // checked by the modifier's set()
        }
        std::error_code ec;
        if (text.empty() || !fs::exists(text, ec))
            throw std::invalid_argument(kv + ": no such file");
        return 0.0;
    }
    }
    return 0.0;
}

// ---- modifier builders -----------------------------------------------------
// `field` is a generic lambda returning a reference to the option it sets,
// for a const or non-const OperationCall.

template <class F, class E>
Modifier choice(const char* name, F field, std::vector<std::pair<std::string, E>> names,
                const char* applies_to, const char* meaning)
{
    Modifier m;
    m.info.name = name;
    m.info.type = ModifierType::Choice;
    for (const auto& n : names)
        m.info.choices.push_back(n.first);
    m.info.applies_to = applies_to;
    m.info.meaning = meaning;
    m.set = [field, names](OperationCall& c, const std::string& text, double) {
        for (const auto& n : names)
            if (n.first == text)
                field(c) = n.second;
    };
    m.get = [field, names](const OperationCall& c) {
        for (const auto& n : names)
            if (n.second == field(c))
                return n.first;
        return std::string("?");
    };
    return m;
}

const std::vector<std::pair<std::string, bool>> kOnOff = {{"on", true}, {"off", false}};

// An Integer or Number modifier; `words` name special values ("auto" = 0).
template <class F>
Modifier number(const char* name, ModifierType type, F field, double min, bool min_open, double max,
                bool max_open, const char* placeholder, const char* unit, const char* applies_to,
                const char* meaning, std::vector<std::pair<std::string, double>> words = {})
{
    Modifier m;
    m.info.name = name;
    m.info.type = type;
    for (const auto& w : words)
        m.info.choices.push_back(w.first);
    m.info.min = min;
    m.info.max = max;
    m.info.min_open = min_open;
    m.info.max_open = max_open;
    m.info.placeholder = placeholder;
    m.info.unit = unit;
    m.info.applies_to = applies_to;
    m.info.meaning = meaning;
    const ModifierInfo info = m.info;
    m.set = [field, words, info](OperationCall& c, const std::string& text, double v) {
        using T = std::decay_t<decltype(field(c))>;
        bool word = false;
        for (const auto& w : words)
            if (w.first == text) {
                v = w.second;
                word = true;
            }
        field(c) = T(v);
        // A value inside the range can round onto an excluded end (phase=0.99999999 -> 1).
        if (!word && !in_range(info, double(field(c))))
            throw std::invalid_argument(info.name + "=" + text + " is " + number_text(double(field(c))) +
                                        " in single precision, outside " + range_text(info));
    };
    m.get = [field, words](const OperationCall& c) {
        const double v = double(field(c));
        for (const auto& w : words)
            if (w.second == v)
                return w.first;
        return number_text(v);
    };
    return m;
}

// normal, max_angle, range: shared by every operation that decodes normals.
template <class F>
std::vector<Modifier> decoding_modifiers(F decoding)
{
    return {
        choice("normal", [decoding](auto& c) -> auto& { return decoding(c).convention; },
               std::vector<std::pair<std::string, NormalConvention>>{
                   {"auto", NormalConvention::Auto},
                   {"opengl", NormalConvention::OpenGL},
                   {"directx", NormalConvention::DirectX}},
               "",
               "green convention: opengl (Y+), directx (Y-), auto: the one with less curl"),
        number("max_angle", ModifierType::Number,
               [decoding](auto& c) -> auto& { return decoding(c).max_angle; }, 0, true, 90, true,
               "DEG", "degrees", "", "clamp grazing normals to this angle from +z"),
        choice("range", [decoding](auto& c) -> auto& { return decoding(c).float_encoding; },
               std::vector<std::pair<std::string, FloatEncoding>>{
                   {"signed", FloatEncoding::Signed}, {"unsigned", FloatEncoding::Unsigned}},
               "", "float/half normals stored in [-1,1] (signed) or [0,1] (unsigned)"),
    };
}

// ---- the operations ---------------------------------------------------------

// The image of a file modifier (mask=FILE, fix=FILE): `given` when the
// caller read it already (the command line reads quietly), else read into
// `storage`; nullptr when there is none.
const ImageBuf* file_image(const ImageBuf* given, const std::string& path, const char* what,
                           ImageBuf& storage)
{
    if (given || path.empty())
        return given;
    if (!read_image(storage, path))
        throw std::runtime_error(std::string(what) + ": " + geterror());
    return &storage;
}

const ImageSlot kNormals{"normals", 2, 4,
                         "tangent-space normal map: 8/16-bit UNORM, half or float; 2 channels "
                         "rebuild z, a 4th is alpha"};

Operation slopes_operation()
{
    Operation op;
    op.info = {"slopes",
               "normal map -> slopes (2 channels gx, gy: height change per texel step along x "
               "and y, in texels)",
               {kNormals},
               {{"slopes", 2, 2, "gx, gy in texels per texel"}},
               {}};
    op.modifiers = decoding_modifiers([](auto& c) -> auto& { return c.slopes.normals; });
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::slopes(dst, *in[0], c.slopes);
    };
    return op;
}

Operation height_operation()
{
    Operation op;
    op.info = {"height",
               "normal map -> displacement (1 channel, texel units: 1.0 = one texel's width; "
               "bumps positive, zero mean)",
               {kNormals},
               {{"height", 1, 1, "height in texels"}},
               {}};
    auto h = [](auto& c) -> auto& { return c.height; };
    op.modifiers = decoding_modifiers([h](auto& c) -> auto& { return h(c).normals; });
    const char* rays = "method=rays";
    const char* poisson = "method=poisson";
    std::vector<Modifier> more = {
        choice("method", [h](auto& c) -> auto& { return h(c).method; },
               std::vector<std::pair<std::string, HeightMethod>>{
                   {"auto", HeightMethod::Auto},
                   {"poisson", HeightMethod::Poisson},
                   {"rays", HeightMethod::Rays}},
               "",
               "poisson: least squares (Frankot-Chellappa); rays: radial ray integration; "
               "auto: poisson, or rays when a ray modifier is given"),
        [h] {
            Modifier m = choice("boundary", [h](auto& c) -> auto& { return h(c).boundary; },
                                std::vector<std::pair<std::string, Boundary>>{
                                    {"auto", Boundary::Auto},
                                    {"periodic", Boundary::Periodic},
                                    {"free", Boundary::Free},
                                    {"clip", Boundary::Free}},
                                "",
                                "periodic: the texture tiles; free (clip for rays): it does not; auto: "
                                "periodic when the slopes are continuous across the wrap seams");
            // Written as each method takes it: rays refuse "free".
            m.get = [h, get = m.get](const OperationCall& c) {
                const std::string name = get(c);
                return name == "free" && h(c).method == HeightMethod::Rays ? std::string("clip") : name;
            };
            return m;
        }(),
        number("highpass", ModifierType::Number, [h](auto& c) -> auto& { return h(c).highpass; },
               0, false, 1e9, false, "R", "texels", poisson,
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
            m.get = [h](const OperationCall& c) {
                return h(c).mask_alpha ? std::string("alpha")
                       : !c.mask_file.empty() ? c.mask_file
                       : h(c).mask ? std::string("image")
                                   : std::string("none");
            };
            return m;
        }(),
        choice("impl", [h](auto& c) -> auto& { return h(c).impl; },
               std::vector<std::pair<std::string, RayImpl>>{{"fast", RayImpl::Fast},
                                                            {"reference", RayImpl::Reference}},
               rays, "fast: cost independent of the radius; reference: walks every ray"),
        number("rays", ModifierType::Integer, [h](auto& c) -> auto& { return h(c).rays; }, 1,
               false, 4096, false, "J", "", rays, "ray directions per texel"),
        number("radius", ModifierType::Number, [h](auto& c) -> auto& { return h(c).radius; }, 0,
               true, 65536, false, "R", "texels", rays, "ray length"),
        number("phase", ModifierType::Number, [h](auto& c) -> auto& { return h(c).phase; }, 0,
               false, 1, true, "PHI", "", rays, "ray angles are 2 pi (j + PHI) / J"),
        choice("directions", [h](auto& c) -> auto& { return h(c).directions; },
               std::vector<std::pair<std::string, RayDirections>>{
                   {"rational", RayDirections::Rational}, {"exact", RayDirections::Exact}},
               rays,
               "rational: integer steps nearest the angles; exact: the angles (impl=reference)"),
        choice("skip", [h](auto& c) -> auto& { return h(c).skip_flat; }, kOnOff, rays,
               "skip tiles whose rays meet only zero slopes (the result is identical)"),
    };
    op.modifiers.insert(op.modifiers.end(), more.begin(), more.end());
    op.finish = [](OperationCall& c, const std::map<std::string, std::string>& given,
                   const std::vector<Modifier>& modifiers) {
        HeightOptions& o = c.height;
        bool ray_option = false, poisson_option = false;
        std::vector<std::string> ray_names, poisson_names;
        for (const Modifier& m : modifiers) {
            const bool rays = m.info.applies_to == "method=rays";
            const bool poisson = m.info.applies_to == "method=poisson";
            if (rays)
                ray_names.push_back(m.info.name);
            if (poisson)
                poisson_names.push_back(m.info.name);
            ray_option |= rays && given.count(m.info.name);
            poisson_option |= poisson && given.count(m.info.name);
        }
        if (o.method == HeightMethod::Auto && ray_option)
            o.method = HeightMethod::Rays;
        if (o.method == HeightMethod::Rays && poisson_option)
            throw std::invalid_argument(listed(poisson_names) + " apply to method=poisson, not to rays");
        if (o.highpass > 0.0f && (o.mask_alpha || !c.mask_file.empty()))
            throw std::invalid_argument("highpass cannot be combined with a mask yet");
        if (o.method == HeightMethod::Poisson && ray_option)
            throw std::invalid_argument(listed(ray_names) + " apply to method=rays");
        const auto b = given.find("boundary");
        const std::string boundary = b == given.end() ? "auto" : b->second;
        if (o.method == HeightMethod::Rays && boundary == "free")
            throw std::invalid_argument("rays take boundary=periodic, clip or auto");
        if (o.method != HeightMethod::Rays && boundary == "clip")
            throw std::invalid_argument("method=poisson takes boundary=periodic, free or auto");
        if (o.method == HeightMethod::Rays && o.impl == RayImpl::Fast &&
            o.directions == RayDirections::Exact)
            throw std::invalid_argument("impl=fast needs directions=rational (or use impl=reference)");
    };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        HeightOptions o = c.height;
        ImageBuf mask;
        o.mask = file_image(o.mask, c.mask_file, "mask", mask);
        return relief::height(dst, *in[0], o);
    };
    return op;
}

Operation correct_operation()
{
    Operation op;
    op.info = {"correct",
               "height map -> distortion-correcting offsets (2 channels du, dv in texture units: "
               "the surface point at u shows the texture at u + offset)",
               {{"height", 1, 4096, "displacement; channel 0 is used"}},
               {{"offsets", 2, 2, "du, dv in texture units (1 = the width, height)"}},
               {}};
    auto k = [](auto& c) -> auto& { return c.correct; };
    op.modifiers = {
        number("scale", ModifierType::Number, [k](auto& c) -> auto& { return k(c).scale; }, 0, true,
               1e9, false, "S", "", "",
               "world height = S x stored height, the texture's width = 1 world unit (auto: "
               "1/width for relief's own heights, in texels)",
               {{"auto", 0.0}}),
        number("theta", ModifierType::Number, [k](auto& c) -> auto& { return k(c).theta; }, 0,
               false, 20, false, "T", "", "", "area exponent (higher: keep areas)"),
        choice("nodes", [k](auto& c) -> auto& { return k(c).nodes; },
               std::vector<std::pair<std::string, CorrectNodes>>{{"corner", CorrectNodes::Corner},
                                                                 {"center", CorrectNodes::Center}},
               "", "mesh nodes at texel corners or centres"),
        choice("boundary", [k](auto& c) -> auto& { return k(c).boundary; },
               std::vector<std::pair<std::string, CorrectBoundary>>{
                   {"auto", CorrectBoundary::Auto},
                   {"periodic", CorrectBoundary::Periodic},
                   {"fixed", CorrectBoundary::Fixed}},
               "",
               "periodic: the texture tiles; fixed: the border stays; auto: periodic when the "
               "height is continuous across the wrap seams"),
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
                const std::size_t a1 = v.find(':'), a2 = v.find(':', a1 + 1);
                if (a2 == std::string::npos)
                    throw std::invalid_argument(
                        "fix=" + v + ": write fix=height:H0:DH (stored height H0, tent half-width DH > 0)");
                ModifierInfo h0, dh;
                h0.name = "fix height";
                h0.type = dh.type = ModifierType::Number;
                h0.min = -1e30;
                h0.max = dh.max = 1e30;
                dh.name = "fix width";
                dh.min_open = true;
                dh.unit = "(DH must be > 0)";
                k(c).fix_height = float(check_value(h0, v.substr(a1 + 1, a2 - a1 - 1)));
                k(c).fix_width = float(check_value(dh, v.substr(a2 + 1)));
            };
            m.get = [k](const OperationCall& c) {
                if (k(c).fix_width > 0.0f)
                    return "height:" + number_text(k(c).fix_height) + ":" +
                           number_text(k(c).fix_width);
                return !c.fix_file.empty() ? c.fix_file
                       : k(c).fix_mask     ? std::string("image")
                                           : std::string("none");
            };
            return m;
        }(),
        number("iterations", ModifierType::Integer,
               [k](auto& c) -> auto& { return k(c).iterations; }, 1, false, 1000000, false, "N", "",
               "", "per coarse-to-fine level (auto: until the tolerance)", {{"auto", 0.0}}),
        number("tolerance", ModifierType::Number, [k](auto& c) -> auto& { return k(c).tolerance; },
               0, true, 1, true, "TOL", "", "",
               "relative energy change at which iterations=auto stops"),
        number("levels", ModifierType::Integer, [k](auto& c) -> auto& { return k(c).levels; }, 1,
               false, 30, false, "N", "", "",
               "coarse-to-fine levels (1 = single resolution; auto: down to 16 texels)",
               {{"auto", 0.0}}),
        number("threshold", ModifierType::Number, [k](auto& c) -> auto& { return k(c).threshold; },
               0, false, 1e9, false, "E", "", "",
               "correct nothing when no triangle's anisotropy or area change exceeds this"),
        choice("skip", [k](auto& c) -> auto& { return k(c).skip_tiles; }, kOnOff, "",
               "skip tiles whose nodes cannot move (the result is identical)"),
        choice("search", [k](auto& c) -> auto& { return k(c).search; },
               std::vector<std::pair<std::string, CorrectSearch>>{{"brent", CorrectSearch::Brent},
                                                                  {"golden", CorrectSearch::Golden},
                                                                  {"ternary", CorrectSearch::Ternary}},
               "",
               "line search per node: Brent's (parabolic, precise relative to the step), golden "
               "section or ternary (the first implementation)"),
        number("relax", ModifierType::Number, [k](auto& c) -> auto& { return k(c).relax; }, 1,
               false, 2, true, "W", "", "",
               "over-relaxation: move W x the searched step when that lowers the energy too "
               "(1 = plain steps)"),
    };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        CorrectOptions o = c.correct;
        ImageBuf fix;
        o.fix_mask = file_image(o.fix_mask, c.fix_file, "fix", fix);
        return relief::correct(dst, *in[0], o);
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
               {}};
    auto b = [](auto& c) -> auto& { return c.bake; };
    op.modifiers = {
        choice("filter", [b](auto& c) -> auto& { return b(c).filter; },
               std::vector<std::pair<std::string, BakeFilter>>{{"bilinear", BakeFilter::Bilinear},
                                                               {"bicubic", BakeFilter::Bicubic}},
               "", "resampling filter (bicubic = Catmull-Rom)"),
        choice("colorspace", [b](auto& c) -> auto& { return b(c).colorspace; },
               std::vector<std::pair<std::string, BakeColorspace>>{
                   {"auto", BakeColorspace::Auto},
                   {"sRGB", BakeColorspace::SRGB},
                   {"srgb", BakeColorspace::SRGB},
                   {"linear", BakeColorspace::Linear},
                   {"raw", BakeColorspace::Raw}},
               "",
               "colour is filtered in linear light via OpenColorIO ($OCIO, else the sRGB curve); "
               "auto: the file's declared space, 8-bit PNG/JPEG as sRGB; raw: no conversion"),
        choice("kind", [b](auto& c) -> auto& { return b(c).kind; },
               std::vector<std::pair<std::string, BakeKind>>{{"auto", BakeKind::Auto},
                                                             {"color", BakeKind::Color},
                                                             {"normal", BakeKind::Normal},
                                                             {"data", BakeKind::Data},
                                                             {"height", BakeKind::Height}},
               "", "normal maps bake as data and are renormalised; height maps are refused"),
        choice("wrap", [b](auto& c) -> auto& { return b(c).wrap; },
               std::vector<std::pair<std::string, BakeWrap>>{{"auto", BakeWrap::Auto},
                                                             {"periodic", BakeWrap::Periodic},
                                                             {"clamp", BakeWrap::Clamp}},
               "", "auto: periodic when the offsets were computed with boundary=periodic"),
    };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::bake(dst, *in[0], *in[1], c.bake);
    };
    return op;
}

const ImageSlot kHeight{"height", 1, 4096, "displacement in texels; channel 0 is used"};

Operation normals_operation()
{
    Operation op;
    op.info = {"normals",
               "height map -> its normal map (3 channels, unit vectors; float files hold [-1, 1], "
               "integer files (v + 1)/2): the inverse of the slopes, by central differences",
               {kHeight},
               {{"normals", 3, 3, "tangent-space normal map in the chosen green convention"}},
               {}};
    auto n = [](auto& c) -> auto& { return c.normals; };
    op.modifiers = {
        choice("normal", [n](auto& c) -> auto& { return n(c).convention; },
               std::vector<std::pair<std::string, NormalConvention>>{
                   {"opengl", NormalConvention::OpenGL}, {"directx", NormalConvention::DirectX}},
               "", "green convention to store: opengl (Y+, G = -n_y) or directx (Y-, G = +n_y)"),
        number("scale", ModifierType::Number, [n](auto& c) -> auto& { return n(c).scale; }, 0, true,
               1e9, false, "S", "", "", "the height (texels) is multiplied by S first"),
        choice("boundary", [n](auto& c) -> auto& { return n(c).boundary; },
               std::vector<std::pair<std::string, Boundary>>{{"auto", Boundary::Auto},
                                                            {"periodic", Boundary::Periodic},
                                                            {"free", Boundary::Free}},
               "",
               "periodic: differences wrap; free: one-sided at the edges; auto: the height's own "
               "(relief:parameters), else periodic when it is continuous across the wrap seams"),
    };
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::normals(dst, *in[0], c.normals);
    };
    return op;
}

// patch, error, scale: shared by --tessellation and --mesh.
template <class F>
std::vector<Modifier> tessellation_modifiers(F t)
{
    return {
        number("patch", ModifierType::Integer, [t](auto& c) -> auto& { return t(c).patch; }, 1, false,
               4096, false, "P", "texels", "", "patch size: one level per P x P texels"),
        number("error", ModifierType::Number, [t](auto& c) -> auto& { return t(c).error; }, 0, true,
               1e9, false, "E", "texels x S", "",
               "the largest deviation of the tessellated surface from S x height at a texel centre"),
        number("scale", ModifierType::Number, [t](auto& c) -> auto& { return t(c).scale; }, 0, true,
               1e9, false, "S", "", "", "the surface is S x height (texels)"),
    };
}

Operation tessellation_operation()
{
    Operation op;
    op.info = {"tessellation",
               "height map -> tessellation levels (1 channel, ceil(W/P) x ceil(H/P)): per patch the "
               "lowest level 1..64 whose L x L quads stay within E of the surface; flat patches 1",
               {kHeight},
               {{"levels", 1, 1, "level per patch, 1..64"}},
               {}};
    op.modifiers = tessellation_modifiers([](auto& c) -> auto& { return c.tessellation; });
    op.run = [](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::tessellation(dst, *in[0], c.tessellation);
    };
    return op;
}

Operation mesh_operation()
{
    Operation op;
    op.info = {"mesh",
               "height map -> a file holding the displaced surface, tessellated per patch at its "
               "level and stitched without cracks (OBJ, PLY, glTF .gltf/.glb by extension; x, y in "
               "texels, z = S x height); the height stays on the stack",
               {kHeight},
               {{"height", 1, 4096, "the input, unchanged"}},
               {}};
    auto k = [](auto& c) -> auto& { return c.mesh; };
    op.modifiers = tessellation_modifiers([k](auto& c) -> auto& { return k(c).tessellation; });
    Modifier out;
    out.info.name = "out";
    out.info.type = ModifierType::Output;
    out.info.placeholder = "FILE";
    out.info.meaning = "the mesh file: .obj, .ply, .gltf or .glb (required)";
    out.set = [k](OperationCall& c, const std::string& text, double) {
        const std::string problem = mesh_path_problem(text);
        if (!problem.empty())
            throw std::invalid_argument(problem);
        k(c).out = text;
    };
    out.get = [k](const OperationCall& c) { return k(c).out.empty() ? std::string("none") : k(c).out; };
    op.modifiers.push_back(out);
    op.finish = [k](OperationCall& c, const std::map<std::string, std::string>&, const std::vector<Modifier>&) {
        if (k(c).out.empty())
            throw std::invalid_argument("give the mesh file: out=FILE.obj|.ply|.gltf|.glb");
    };
    op.run = [k](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::mesh(dst, *in[0], k(c));
    };
    return op;
}

Operation preview_operation()
{
    Operation op;
    op.info = {"preview",
               "normal map and height -> one labelled 8-bit RGB sheet: both lit under the same light, "
               "an emboss view, the angular error (heat map, degrees) and the height (texels)",
               {kNormals, kHeight},
               {{"sheet", 3, 3, "sRGB preview sheet"}},
               {}};
    auto k = [](auto& c) -> auto& { return c.preview; };
    op.modifiers = decoding_modifiers([k](auto& c) -> auto& { return k(c).normals; });
    Modifier light;
    light.info.name = "light";
    light.info.type = ModifierType::Text;
    light.info.placeholder = "AZ,EL";
    light.info.unit = "degrees";
    light.info.meaning = "key light: azimuth counter-clockwise from the image's right (90 = from the top), "
                         "in [-360, 360]; elevation above the surface, in (0, 90]";
    light.set = [k](OperationCall& c, const std::string& text, double) {
        const std::size_t comma = text.find(',');
        if (comma == std::string::npos)
            throw std::invalid_argument("light=" + text + ": write light=AZ,EL (degrees, e.g. 135,45)");
        ModifierInfo az, el;
        az.name = "light azimuth";
        el.name = "light elevation";
        az.type = el.type = ModifierType::Number;
        az.min = -360;
        az.max = 360;
        el.min = 0;
        el.min_open = true;
        el.max = 90;
        az.unit = el.unit = "degrees";
        k(c).azimuth = float(check_value(az, text.substr(0, comma)));
        k(c).elevation = float(check_value(el, text.substr(comma + 1)));
    };
    light.get = [k](const OperationCall& c) {
        return number_text(k(c).azimuth) + "," + number_text(k(c).elevation);
    };
    Modifier env;
    env.info.name = "env";
    env.info.type = ModifierType::File;
    env.info.choices = {"sky"};
    env.info.placeholder = "FILE";
    env.info.meaning = "lat-long environment image for the diffuse light (its 9 spherical-harmonic "
                       "irradiance coefficients; 8/16-bit files are sRGB); sky: a procedural sky";
    env.set = [k](OperationCall& c, const std::string& text, double) { k(c).env = text == "sky" ? "" : text; };
    env.get = [k](const OperationCall& c) { return k(c).env.empty() ? std::string("sky") : k(c).env; };
    op.modifiers.push_back(light);
    op.modifiers.push_back(env);
    op.modifiers.push_back(choice("boundary", [k](auto& c) -> auto& { return k(c).boundary; },
                                  std::vector<std::pair<std::string, Boundary>>{{"auto", Boundary::Auto},
                                                                               {"periodic", Boundary::Periodic},
                                                                               {"free", Boundary::Free}},
                                  "", "of the height's differences, as --normals"));
    op.run = [k](ImageBuf& dst, const OperationCall& c, const std::vector<const ImageBuf*>& in) {
        return relief::preview(dst, *in[0], *in[1], k(c));
    };
    return op;
}

const std::vector<Operation>& table()
{
    static const std::vector<Operation> ops = [] {
        std::vector<Operation> v = {slopes_operation(), height_operation(), correct_operation(),
                                    bake_operation(), normals_operation(), tessellation_operation(),
                                    mesh_operation(), preview_operation()};
        const OperationCall defaults;
        for (Operation& op : v)
            for (Modifier& m : op.modifiers) {
                m.info.default_value = m.get(defaults);
                op.info.modifiers.push_back(m.info);
            }
        return v;
    }();
    return ops;
}

const Operation* find(const std::string& name)
{
    for (const Operation& op : table())
        if (op.info.name == name)
            return &op;
    return nullptr;
}

const Operation& find_or_throw(const std::string& name)
{
    if (const Operation* op = find(name))
        return *op;
    std::string known;
    for (const Operation& op : table())
        known += (known.empty() ? "" : ", ") + op.info.name;
    throw std::invalid_argument("unknown operation '" + name + "' (known: " + known + ")");
}

// "key=value:key=value" -> pairs; fix=height:H0:DH keeps its colons.
std::vector<std::pair<std::string, std::string>> split(const Operation& op, const std::string& text)
{
    std::vector<std::pair<std::string, std::string>> kv;
    if (text.empty())
        return kv;
    std::size_t pos = 0;
    for (bool last = false; !last;) {
        const std::size_t next = text.find(':', pos);
        last = next == std::string::npos;
        const std::string item = text.substr(pos, last ? next : next - pos);
        pos = next + 1;
        const std::size_t eq = item.find('=');
        // A word with arguments (fix=height:H0:DH) takes the items after it.
        bool continues = false;
        if (eq == std::string::npos && !item.empty() && !kv.empty())
            for (const Modifier& m : op.modifiers)
                if (m.info.name == kv.back().first)
                    for (const auto& w : m.info.choices)
                        continues |= !word_prefix(w).empty() &&
                                     kv.back().second.rfind(w.substr(0, w.find(':')), 0) == 0;
        if (continues)
            kv.back().second += ":" + item;
        else if (item.empty() || eq == std::string::npos || eq == 0)
            throw std::invalid_argument("modifier '" + item + "' is not key=value");
        else
            kv.emplace_back(item.substr(0, eq), item.substr(eq + 1));
    }
    return kv;
}

void parse(OperationCall& call, const Operation& op,
           const std::vector<std::pair<std::string, std::string>>& modifiers)
{
    OperationCall c;
    c.operation = op.info.name;
    std::map<std::string, std::string> given;
    for (const auto& [key, value] : modifiers) {
        const Modifier* m = nullptr;
        for (const Modifier& candidate : op.modifiers)
            if (candidate.info.name == key)
                m = &candidate;
        if (!m) {
            std::string known;
            for (const Modifier& candidate : op.modifiers)
                known += (known.empty() ? "" : ", ") + candidate.info.name;
            throw std::invalid_argument("unknown modifier '" + key + "' (known: " + known + ")");
        }
        if (!given.emplace(key, value).second)
            throw std::invalid_argument("modifier '" + key + "' given twice");
        m->set(c, value, check_value(m->info, value));
    }
    if (op.finish)
        op.finish(c, given, op.modifiers);
    call = std::move(c);
}

std::string json_string(const std::string& s)
{
    std::string out = "\"";
    for (const char ch : s) {
        const unsigned char u = static_cast<unsigned char>(ch);
        if (ch == '"' || ch == '\\')
            out += std::string("\\") + ch;
        else if (u < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", u);
            out += buf;
        } else
            out += ch;
    }
    return out + "\"";
}

const char* type_name(ModifierType t)
{
    switch (t) {
    case ModifierType::Choice: return "choice";
    case ModifierType::Integer: return "integer";
    case ModifierType::Number: return "number";
    case ModifierType::File: return "file";
    case ModifierType::Output: return "output";
    case ModifierType::Text: return "text";
    }
    return "?";
}

std::string json_slots(const std::vector<ImageSlot>& slots)
{
    std::string s = "[";
    for (std::size_t i = 0; i < slots.size(); ++i)
        s += std::string(i ? ", " : "") + "{\"name\": " + json_string(slots[i].name) +
             ", \"min_channels\": " + std::to_string(slots[i].min_channels) +
             ", \"max_channels\": " + std::to_string(slots[i].max_channels) +
             ", \"meaning\": " + json_string(slots[i].meaning) + "}";
    return s + "]";
}

} // namespace

std::string range_text(const ModifierInfo& m)
{
    std::string r = std::string(m.min_open ? "(" : "[") + number_text(m.min) + ", " +
                    number_text(m.max) + (m.max_open ? ")" : "]");
    return m.unit.empty() ? r : r + " " + m.unit;
}

std::string input_problem(const std::string& operation, const ImageSlot& slot, int width, int height,
                          int channels)
{
    const std::string what = operation + ": input '" + slot.name + "'";
    if (width <= 0 || height <= 0)
        return what + " is " + std::to_string(width) + "x" + std::to_string(height) +
               " texels; both must be > 0";
    if (channels < slot.min_channels || channels > slot.max_channels)
        return what + " has " + std::to_string(channels) + " channel(s); " + operation + " takes " +
               std::to_string(slot.min_channels) + " to " + std::to_string(slot.max_channels);
    return "";
}

const std::vector<OperationInfo>& operations()
{
    static const std::vector<OperationInfo> infos = [] {
        std::vector<OperationInfo> v;
        for (const Operation& op : table())
            v.push_back(op.info);
        return v;
    }();
    return infos;
}

const OperationInfo* find_operation(const std::string& name)
{
    for (const OperationInfo& op : operations())
        if (op.name == name)
            return &op;
    return nullptr;
}

std::string operations_json()
{
    std::ostringstream j;
    j << "{\"abi_version\": 1, \"operations\": [";
    bool first_op = true;
    for (const OperationInfo& op : operations()) {
        j << (first_op ? "\n" : ",\n") << "  {\"name\": " << json_string(op.name)
          << ", \"summary\": " << json_string(op.summary) << ",\n   \"inputs\": "
          << json_slots(op.inputs) << ",\n   \"outputs\": " << json_slots(op.outputs)
          << ",\n   \"modifiers\": [";
        first_op = false;
        bool first = true;
        for (const ModifierInfo& m : op.modifiers) {
            j << (first ? "\n" : ",\n") << "    {\"name\": " << json_string(m.name)
              << ", \"type\": \"" << type_name(m.type) << "\"";
            first = false;
            j << ", \"choices\": [";
            for (std::size_t i = 0; i < m.choices.size(); ++i)
                j << (i ? ", " : "") << json_string(m.choices[i]);
            j << "]";
            if (m.type == ModifierType::Integer || m.type == ModifierType::Number)
                j << ", \"min\": " << number_text(m.min) << ", \"max\": " << number_text(m.max)
                  << ", \"min_open\": " << (m.min_open ? "true" : "false")
                  << ", \"max_open\": " << (m.max_open ? "true" : "false")
                  << ", \"unit\": " << json_string(m.unit);
            j << ", \"default\": " << json_string(m.default_value)
              << ", \"applies_to\": " << json_string(m.applies_to)
              << ", \"meaning\": " << json_string(m.meaning) << "}";
        }
        j << "]}";
    }
    j << "\n]}\n";
    return j.str();
}

bool parse_modifiers(OperationCall& call, const std::string& operation,
                     const std::vector<std::pair<std::string, std::string>>& modifiers)
{
    try {
        parse(call, find_or_throw(operation), modifiers);
        return true;
    } catch (const std::exception& e) {
        detail::set_error(e.what());
        return false;
    }
}

bool parse_modifiers(OperationCall& call, const std::string& operation, const std::string& modifiers)
{
    try {
        const Operation& op = find_or_throw(operation);
        parse(call, op, split(op, modifiers));
        return true;
    } catch (const std::exception& e) {
        detail::set_error(e.what());
        return false;
    }
}

bool run_operation(ImageBuf& dst, const OperationCall& call,
                   const std::vector<const ImageBuf*>& inputs, const Execution& exec)
{
    try {
        const Operation& op = find_or_throw(call.operation);
        if (inputs.size() != op.info.inputs.size())
            throw std::invalid_argument(op.info.name + " takes " +
                                        std::to_string(op.info.inputs.size()) + " image(s), got " +
                                        std::to_string(inputs.size()));
        // Channel counts are the operations' own to check (their messages say
        // what the channels mean); the C ABI and Python check them against the
        // table's slots before converting.
        for (std::size_t i = 0; i < inputs.size(); ++i)
            if (!inputs[i])
                throw std::invalid_argument(op.info.name + ": input '" + op.info.inputs[i].name +
                                            "' is missing (null)");
        OperationCall c = call;
        c.slopes.exec = c.height.exec = c.correct.exec = c.bake.exec = exec;
        c.normals.exec = c.tessellation.exec = c.mesh.tessellation.exec = c.preview.exec = exec;
        return op.run(dst, c, inputs);
    } catch (const std::exception& e) {
        detail::set_error(e.what());
        return false;
    }
}

std::string modifier_text(const OperationCall& call)
{
    std::string text;
    for (const Modifier& m : find_or_throw(call.operation).modifiers)
        text += (text.empty() ? "" : ":") + m.info.name + "=" + m.get(call);
    return text;
}

std::string implementation_digest()
{
    std::vector<std::string> parts = {version()};
    for (const host::EmbeddedSource& s : host::embedded_kernel_sources()) {
        parts.push_back(s.name);
        parts.push_back(host::kernel_source(s.name));
    }
    return host::BinaryCache::key(parts);
}

void detail::check_modifier_values(const std::string& operation, const OperationCall& call)
{
    for (const Modifier& m : find_or_throw(operation).modifiers) {
        if (m.info.type == ModifierType::File || m.info.type == ModifierType::Output)
            continue;  // images come as pointers here; fix's tent is checked by correct(), paths by their writers
        check_value(m.info, m.get(call));
    }
}

} // namespace relief
