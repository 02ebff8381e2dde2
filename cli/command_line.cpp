#include "command_line.h"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

namespace relief::cli {

namespace fs = std::filesystem;

const char* usage_text()
{
    return R"(relief — normal maps to displacement maps (OpenCL)

Usage: relief [options] ARG...
Arguments are read left to right over a stack of images, like oiiotool:
  FILE                  push an image (read as raw data, no colour conversion)
  --slopes[:MODS]       pop a normal map, push its slopes (2 channels gx, gy:
                        height change per texel step along x and y, texels)
  --height[:MODS]       pop a normal map, push its displacement (1 channel,
                        texel units: 1.0 = one texel's width; bumps positive,
                        zero mean)
  --correct[:MODS]      pop a height map, push its distortion-correcting
                        offset map (2 channels du, dv in texture units:
                        1 = the width, height; the surface point at u
                        shows the texture at u + offset)
  --bake[:MODS]         pop an offset map and the texture below it, push the
                        texture resampled at u + offset(u)
  -o FILE               write the top of the stack (atomically)
  -d TYPE               pixel type for the following -o: float (default),
                        half, uint16, uint8; integer files store
                        data = (value - 0.5) * scale, scale printed and stored
  --compression NAME    file compression for the following -o, by OIIO's
                        names (zip, piz, none...); default none for float
                        EXR (float heights barely compress), else the
                        format's own
Modifiers (:key=value) of --slopes and --height:
  normal=auto|opengl|directx   green convention (auto: the one with less curl)
  max_angle=DEG         clamp grazing normals to DEG from +z (default 85)
  range=signed|unsigned float/half normals in [-1,1] (default) or [0,1]
Modifiers of --height:
  method=auto|poisson|rays  auto (default): poisson, or rays when a ray
                        modifier below is given
  boundary=auto|periodic|free|clip  periodic: the texture tiles; free (clip
                        for rays): it does not; auto (default): periodic when
                        the slopes are continuous across the wrap seams
  method=poisson: least squares (Frankot-Chellappa: the height whose
                        gradient is closest to the slopes)
    highpass=R          relief balance: remove structure larger than R
                        texels (default 0 = off)
    mask=FILE|alpha     per-texel weights in [0,1] (channel 0 of FILE, or
                        the normal map's alpha); 0 excludes a texel's slopes
  method=rays: radial ray integration (height minus its mean over the disk
                        of radius R, from J rays per texel)
    impl=fast|reference fast (default): cost independent of the radius
    rays=J              ray directions (default 32)
    radius=R            ray length in texels (default 64)
    phase=PHI           angles 2*pi*(j+PHI)/J, PHI in [0,1) (default 0.5)
    directions=rational|exact  integer steps nearest the angles (default),
                        or the angles themselves (impl=reference only)
    skip=on|off         skip tiles whose rays meet only zero slopes (default
                        on; the result is identical)
Modifiers of --correct:
  scale=S               world height = S x stored height, the texture's width
                        = 1 world unit (required unless the height map is
                        relief's own, in texels: then 1/width)
  theta=5               area exponent, 0..20 (higher: keep areas)
  nodes=corner|center   mesh nodes at texel corners (default) or centres
  boundary=auto|periodic|fixed  periodic: the texture tiles; fixed: the
                        border stays; auto: periodic when the height is
                        continuous across the wrap seams
  fix=FILE|height:H0:DH keep texels with weight w within 1/w texels: w from
                        channel 0 of FILE, or max(0, 1-|h-H0|/DH)
  iterations=auto|N     per coarse-to-fine level (auto: until tolerance)
  tolerance=1e-5        relative energy change at which auto stops
  levels=auto|N         coarse-to-fine levels (1 = single resolution)
  threshold=1e-3        correct nothing when no triangle's anisotropy or
                        area change exceeds this (zero offsets)
  skip=on|off           skip tiles whose nodes cannot move (same result)
Modifiers of --bake:
  filter=bilinear|bicubic  (default bilinear; bicubic = Catmull-Rom)
  colorspace=auto|sRGB|linear|raw  colour is decoded to linear light with
                        OpenColorIO ($OCIO, else the sRGB curve), filtered,
                        encoded back; auto: the file's declared space, 8-bit
                        PNG/JPEG as sRGB; raw: no conversion
  kind=auto|color|normal|data|height  normal maps bake as data and are
                        renormalised; height maps are refused
  wrap=auto|periodic|clamp  auto: periodic when the offsets were computed
                        with boundary=periodic
Options:
  --report FILE.json    write the --correct step's report: energy, iterations,
                        anisotropy and area ratio before/after, time
  --device DEV          auto (default: a GPU if any, else the CPU), gpu, cpu,
                        or PLATFORM:DEVICE as --list-devices numbers them
  --list-devices        list the OpenCL devices and exit
  -v                    say what was chosen (device, convention), progress,
                        times, and the image libraries' own diagnostics
  --help, --version
Environment:
  RELIEF_DEVICE_MAX_ALLOC=BYTES  the largest device buffer to allocate (default
                        and upper bound: the device's own limit); larger
                        needs are refused with the numbers
Example:
  relief normal.png --height -o height.exr
  relief height.png --correct:scale=0.05:nodes=center -o offsets.exr
  relief albedo.png height.png --correct:scale=0.05 -o offsets.exr --bake -o albedo_fixed.png
  relief normal.png --height:normal=directx:rays=16:radius=32:boundary=clip -o height.exr
)";
}

namespace {

struct Modifiers {
    std::string command;
    std::map<std::string, std::string> values;
};

Modifiers split_modifiers(const std::string& arg)
{
    Modifiers m;
    std::string last_key;
    std::size_t pos = arg.find(':');
    m.command = arg.substr(0, pos);
    while (pos != std::string::npos) {
        std::size_t next = arg.find(':', pos + 1);
        std::string kv = arg.substr(pos + 1, next == std::string::npos ? next : next - pos - 1);
        std::size_t eq = kv.find('=');
        // fix=height:H0:DH carries its own colons.
        if (eq == std::string::npos && !kv.empty() && m.values.count("fix") &&
            m.values["fix"].rfind("height", 0) == 0 && last_key == "fix") {
            m.values["fix"] += ":" + kv;
            pos = next;
            continue;
        }
        if (kv.empty() || eq == std::string::npos || eq == 0)
            throw UsageError(arg + ": modifier '" + kv + "' is not key=value");
        std::string key = kv.substr(0, eq);
        if (m.values.count(key))
            throw UsageError(arg + ": modifier '" + key + "' given twice");
        m.values[key] = kv.substr(eq + 1);
        last_key = key;
        pos = next;
    }
    return m;
}

double parse_number(const std::string& arg, const std::string& key, const std::string& text)
{
    double v = 0.0;
    const char* end = text.data() + text.size();
    auto r = std::from_chars(text.data(), end, v);
    if (text.empty() || r.ec != std::errc() || r.ptr != end || !std::isfinite(v))
        throw UsageError(arg + ": " + key + "=" + text + " is not a number");
    return v;
}

double parse_in_range(const std::string& arg, const std::string& key, const std::string& text,
                      double lo, bool lo_open, double hi, bool hi_open, const char* what)
{
    double v = parse_number(arg, key, text);
    if ((lo_open ? v <= lo : v < lo) || (hi_open ? v >= hi : v > hi))
        throw UsageError(arg + ": " + key + "=" + text + " is out of range; " + what);
    return v;
}

int parse_int(const std::string& arg, const std::string& key, const std::string& text, int lo,
              int hi)
{
    int v = 0;
    const char* end = text.data() + text.size();
    auto r = std::from_chars(text.data(), end, v);
    if (text.empty() || r.ec != std::errc() || r.ptr != end || v < lo || v > hi)
        throw UsageError(arg + ": " + key + "=" + text + " must be an integer in [" +
                         std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
}

std::string choice(const std::string& arg, const std::string& key, const std::string& text,
                   std::initializer_list<const char*> allowed)
{
    std::string list;
    for (const char* a : allowed) {
        if (text == a)
            return text;
        list += list.empty() ? a : std::string("|") + a;
    }
    throw UsageError(arg + ": " + key + "=" + text + " is not one of " + list);
}

// Applies the normal-decoding modifiers; returns false if `key` is not one.
bool apply_decoding(NormalDecoding& d, const std::string& arg, const std::string& key,
                    const std::string& v)
{
    if (key == "normal") {
        std::string c = choice(arg, key, v, {"auto", "opengl", "directx"});
        d.convention = c == "opengl"    ? NormalConvention::OpenGL
                       : c == "directx" ? NormalConvention::DirectX
                                        : NormalConvention::Auto;
    } else if (key == "max_angle") {
        d.max_angle = float(parse_in_range(arg, key, v, 0, true, 90, true, "degrees in (0, 90)"));
    } else if (key == "range") {
        d.float_encoding = choice(arg, key, v, {"signed", "unsigned"}) == "unsigned"
                               ? FloatEncoding::Unsigned
                               : FloatEncoding::Signed;
    } else {
        return false;
    }
    return true;
}

[[noreturn]] void unknown_modifier(const std::string& arg, const std::string& key,
                                   const char* known)
{
    throw UsageError(arg + ": unknown modifier '" + key + "' (known: " + known + ")");
}

Step make_step(Step::Kind kind, const std::string& text, const std::string& path = "")
{
    Step s{};
    s.kind = kind;
    s.text = text;
    s.path = path;
    return s;
}

Step parse_slopes(const std::string& arg)
{
    Step s = make_step(Step::Kind::Slopes, arg);
    for (const auto& [key, v] : split_modifiers(arg).values)
        if (!apply_decoding(s.slopes.normals, arg, key, v))
            unknown_modifier(arg, key, "normal, max_angle, range");
    return s;
}

Step parse_height(const std::string& arg)
{
    Step s = make_step(Step::Kind::Height, arg);
    HeightOptions& h = s.height;
    bool ray_option = false, poisson_option = false;
    std::string method = "auto", boundary;
    for (const auto& [key, v] : split_modifiers(arg).values) {
        if (apply_decoding(h.normals, arg, key, v))
            continue;
        const bool ray_key = key == "impl" || key == "directions" || key == "rays" ||
                             key == "radius" || key == "phase" || key == "skip";
        ray_option |= ray_key;
        if (key == "method")
            method = choice(arg, key, v, {"auto", "rays", "poisson"});
        else if (key == "impl")
            h.impl = choice(arg, key, v, {"fast", "reference"}) == "fast" ? RayImpl::Fast
                                                                          : RayImpl::Reference;
        else if (key == "directions")
            h.directions = choice(arg, key, v, {"rational", "exact"}) == "rational"
                               ? RayDirections::Rational
                               : RayDirections::Exact;
        else if (key == "rays")
            h.rays = parse_int(arg, key, v, 1, 4096);
        else if (key == "radius")
            h.radius = float(parse_in_range(arg, key, v, 0, true, 65536, false,
                                            "texels in (0, 65536]"));
        else if (key == "phase")
            h.phase = float(parse_in_range(arg, key, v, 0, false, 1, true, "in [0, 1)"));
        else if (key == "boundary")
            boundary = choice(arg, key, v, {"auto", "periodic", "free", "clip"});
        else if (key == "skip")
            h.skip_flat = choice(arg, key, v, {"on", "off"}) == "on";
        else if (key == "mask") {
            poisson_option = true;
            if (v == "alpha")
                h.mask_alpha = true;
            else {
                std::error_code ec;
                if (v.empty() || !fs::exists(v, ec))
                    throw UsageError(arg + ": mask=" + v + ": no such file");
                s.mask = v;
            }
        } else if (key == "highpass") {
            poisson_option = true;
            h.highpass = float(parse_in_range(arg, key, v, 0, false, 1e9, false,
                                              "a radius in texels >= 0 (0 = off)"));
        } else
            unknown_modifier(arg, key,
                             "method, boundary, normal, max_angle, range, impl, rays, radius, "
                             "phase, directions, skip, highpass, mask");
    }
    if (method == "auto")
        method = ray_option ? "rays" : "auto";
    if (method == "rays" && poisson_option)
        throw UsageError(arg + ": highpass and mask apply to method=poisson, not to rays");
    if (h.highpass > 0.0f && (h.mask_alpha || !s.mask.empty()))
        throw UsageError(arg + ": highpass cannot be combined with a mask yet");
    if (method == "poisson" && ray_option)
        throw UsageError(arg + ": impl, directions, rays, radius, phase and skip apply to method=rays");
    if (method == "rays" && boundary == "free")
        throw UsageError(arg + ": rays take boundary=periodic, clip or auto");
    if (method != "rays" && boundary == "clip")
        throw UsageError(arg + ": method=poisson takes boundary=periodic, free or auto");
    if (method == "rays" && h.impl == RayImpl::Fast && h.directions == RayDirections::Exact)
        throw UsageError(arg + ": impl=fast needs directions=rational (or use impl=reference)");
    h.method = method == "rays" ? HeightMethod::Rays
             : method == "poisson" ? HeightMethod::Poisson
                                   : HeightMethod::Auto;
    h.boundary = boundary == "periodic" ? Boundary::Periodic
               : boundary == "free" || boundary == "clip" ? Boundary::Free
                                                          : Boundary::Auto;
    return s;
}

Step parse_correct(const std::string& arg)
{
    Step s = make_step(Step::Kind::Correct, arg);
    CorrectOptions& c = s.correct;
    for (const auto& [key, v] : split_modifiers(arg).values) {
        if (key == "scale")
            c.scale = float(parse_in_range(arg, key, v, 0, true, 1e9, false, "a scale > 0"));
        else if (key == "theta")
            c.theta = float(parse_in_range(arg, key, v, 0, false, 20, false, "in [0, 20]"));
        else if (key == "nodes")
            c.nodes = choice(arg, key, v, {"corner", "center"}) == "corner" ? CorrectNodes::Corner
                                                                           : CorrectNodes::Center;
        else if (key == "boundary") {
            const std::string b = choice(arg, key, v, {"auto", "periodic", "fixed"});
            c.boundary = b == "periodic" ? CorrectBoundary::Periodic
                       : b == "fixed"    ? CorrectBoundary::Fixed
                                         : CorrectBoundary::Auto;
        } else if (key == "fix") {
            if (v.rfind("height", 0) == 0) {
                const std::size_t a1 = v.find(':'), a2 = a1 == std::string::npos ? a1 : v.find(':', a1 + 1);
                if (v.compare(0, 7, "height:") != 0 || a2 == std::string::npos)
                    throw UsageError(arg + ": fix=" + v + ": write fix=height:H0:DH (stored height H0, tent half-width DH > 0)");
                c.fix_height = float(parse_number(arg, "fix height", v.substr(a1 + 1, a2 - a1 - 1)));
                c.fix_width = float(parse_in_range(arg, "fix width", v.substr(a2 + 1), 0, true, 1e30,
                                                   false, "DH must be > 0"));
                continue;
            }
            std::error_code ec;
            if (v.empty() || !fs::exists(v, ec))
                throw UsageError(arg + ": fix=" + v + ": no such file");
            s.fix_mask = v;
        } else if (key == "iterations")
            c.iterations = v == "auto" ? 0 : parse_int(arg, key, v, 1, 1000000);
        else if (key == "tolerance")
            c.tolerance = float(parse_in_range(arg, key, v, 0, true, 1, true, "in (0, 1)"));
        else if (key == "levels")
            c.levels = v == "auto" ? 0 : parse_int(arg, key, v, 1, 30);
        else if (key == "threshold")
            c.threshold = float(parse_in_range(arg, key, v, 0, false, 1e9, false, ">= 0"));
        else if (key == "skip")
            c.skip_tiles = choice(arg, key, v, {"on", "off"}) == "on";
        else
            unknown_modifier(arg, key,
                             "scale, theta, nodes, boundary, fix, iterations, tolerance, levels, "
                             "threshold, skip");
    }
    return s;
}

Step parse_bake(const std::string& arg)
{
    Step s = make_step(Step::Kind::Bake, arg);
    BakeOptions& b = s.bake;
    for (const auto& [key, v] : split_modifiers(arg).values) {
        if (key == "filter")
            b.filter = choice(arg, key, v, {"bilinear", "bicubic"}) == "bicubic" ? BakeFilter::Bicubic
                                                                             : BakeFilter::Bilinear;
        else if (key == "colorspace") {
            const std::string c = choice(arg, key, v, {"auto", "sRGB", "srgb", "linear", "raw"});
            b.colorspace = c == "sRGB" || c == "srgb" ? BakeColorspace::SRGB
                         : c == "linear"              ? BakeColorspace::Linear
                         : c == "raw"                 ? BakeColorspace::Raw
                                                      : BakeColorspace::Auto;
        } else if (key == "kind") {
            const std::string k = choice(arg, key, v, {"auto", "color", "normal", "data", "height"});
            b.kind = k == "color"    ? BakeKind::Color
                   : k == "normal"   ? BakeKind::Normal
                   : k == "data"     ? BakeKind::Data
                   : k == "height"   ? BakeKind::Height
                                     : BakeKind::Auto;
        } else if (key == "wrap") {
            const std::string w = choice(arg, key, v, {"auto", "periodic", "clamp"});
            b.wrap = w == "periodic" ? BakeWrap::Periodic : w == "clamp" ? BakeWrap::Clamp : BakeWrap::Auto;
        } else
            unknown_modifier(arg, key, "filter, colorspace, kind, wrap");
    }
    return s;
}

OIIO::TypeDesc parse_format(const std::string& t)
{
    if (t == "float")
        return OIIO::TypeDesc::FLOAT;
    if (t == "half")
        return OIIO::TypeDesc::HALF;
    if (t == "uint16")
        return OIIO::TypeDesc::UINT16;
    if (t == "uint8")
        return OIIO::TypeDesc::UINT8;
    throw UsageError("-d " + t + ": unknown type (float, half, uint16, uint8)");
}

} // namespace

Program parse_command_line(const std::vector<std::string>& args)
{
    Program prog;
    OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT;
    bool format_given = false;
    std::string compression;
    int depth = 0;  // stack depth as the program will run
    auto need = [&](const std::string& arg, int n) {
        if (depth < n)
            throw UsageError(arg + " needs " + std::to_string(n) + " image(s) on the stack, has " +
                             std::to_string(depth) + " (give the input file before it)");
    };
    auto value_of = [&](std::size_t& i) -> const std::string& {
        if (i + 1 >= args.size())
            throw UsageError(args[i] + " needs a value");
        return args[++i];
    };

    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        const std::string cmd = a.substr(0, a.find(':'));
        if (a == "--help" || a == "-h") {
            prog.help = true;
        } else if (a == "--version") {
            prog.version = true;
        } else if (a == "-v") {
            prog.verbose = true;
        } else if (a == "--list-devices") {
            prog.list_devices = true;
        } else if (a == "--report") {
            prog.report = value_of(i);
            const fs::path folder = fs::path(prog.report).parent_path();
            std::error_code ec;
            if (prog.report.empty() || fs::is_directory(prog.report, ec) ||
                !fs::is_directory(folder.empty() ? fs::path(".") : folder, ec))
                throw UsageError("--report " + prog.report + ": not a writable file path (its folder must exist)");
        } else if (a == "--device") {
            prog.device = value_of(i);
        } else if (a == "-d") {
            format = parse_format(value_of(i));
            format_given = true;
        } else if (a == "--compression") {
            compression = value_of(i);
            if (compression.empty())
                throw UsageError("--compression needs a name (e.g. zip, piz, none)");
        } else if (a == "-o") {
            const std::string& path = value_of(i);
            need(a, 1);
            if (!check_output_path(path))
                throw UsageError("-o " + path + ": " + geterror());
            Step w = make_step(Step::Kind::Write, "-o " + path, path);
            w.format = format;
            w.format_given = format_given;
            w.compression = compression;
            prog.steps.push_back(w);
        } else if (cmd == "--slopes") {
            need(cmd, 1);
            prog.steps.push_back(parse_slopes(a));
        } else if (cmd == "--height") {
            need(cmd, 1);
            prog.steps.push_back(parse_height(a));
        } else if (cmd == "--correct") {
            need(cmd, 1);
            prog.steps.push_back(parse_correct(a));
        } else if (cmd == "--bake") {
            need(cmd, 2);
            prog.steps.push_back(parse_bake(a));
            --depth;
        } else if (!a.empty() && a[0] == '-' && a != "-") {
            throw UsageError("unknown option '" + a + "' (see relief --help)");
        } else {
            std::error_code ec;
            if (!fs::exists(a, ec))
                throw UsageError("cannot read '" + a + "': no such file");
            prog.steps.push_back(make_step(Step::Kind::Read, a, a));
            ++depth;
        }
    }
    int corrections = 0;
    for (const Step& s : prog.steps)
        corrections += s.kind == Step::Kind::Correct;
    if (!prog.report.empty() && corrections != 1)
        throw UsageError("--report needs exactly one --correct, there are " + std::to_string(corrections));
    for (Step& s : prog.steps) {
        s.correct.exec.device = prog.device;
        s.bake.exec.device = prog.device;
        s.slopes.exec.device = prog.device;
        s.height.exec.device = prog.device;
    }
    return prog;
}

} // namespace relief::cli
