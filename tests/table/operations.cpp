// SPDX-License-Identifier: Apache-2.0
// The operation table (relief/operations.h): one description that the
// parser, --help, the JSON of the C ABI, the API's range checks and
// run_operation() all follow.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <future>
#include <regex>
#include <string>
#include <vector>

#include "command_line.h"
#include "relief/relief.h"
#include "relief/relief_c.h"
#include "support/fields.h"
#include "support/images.h"

using namespace relief;
using OIIO::ImageBuf;

using relief::test::kSampleHeight;

namespace {

bool same_tessellation(const TessellationOptions& a, const TessellationOptions& b)
{
    return a.patch == b.patch && a.error == b.error && a.scale == b.scale;
}

// Every option field the table can set, compared.
bool same_options(const OperationCall& a, const OperationCall& b)
{
    auto dec = [](const NormalDecoding& x, const NormalDecoding& y) {
        return x.convention == y.convention && x.max_angle == y.max_angle &&
               x.float_encoding == y.float_encoding;
    };
    const HeightOptions &h = a.height, &g = b.height;
    const CorrectOptions &c = a.correct, &d = b.correct;
    return dec(a.slopes.normals, b.slopes.normals) && dec(h.normals, g.normals) && h.method == g.method &&
           h.boundary == g.boundary && h.impl == g.impl && h.rays == g.rays && h.radius == g.radius &&
           h.phase == g.phase && h.directions == g.directions && h.skip_flat == g.skip_flat &&
           h.highpass == g.highpass && h.udim == g.udim && h.mask_alpha == g.mask_alpha &&
           a.mask_file == b.mask_file && c.scale == d.scale && c.theta == d.theta && c.nodes == d.nodes &&
           c.boundary == d.boundary && c.fix_height == d.fix_height && c.fix_width == d.fix_width &&
           a.fix_file == b.fix_file && c.iterations == d.iterations && c.tolerance == d.tolerance &&
           c.levels == d.levels && c.threshold == d.threshold && c.skip_tiles == d.skip_tiles &&
           c.search == d.search && c.relax == d.relax && c.hats == d.hats && c.global == d.global &&
           c.polish == d.polish && a.bake.filter == b.bake.filter && a.bake.colorspace == b.bake.colorspace &&
           a.bake.kind == b.bake.kind && a.bake.wrap == b.bake.wrap &&
           a.normals.convention == b.normals.convention && a.normals.scale == b.normals.scale &&
           a.normals.boundary == b.normals.boundary && same_tessellation(a.tessellation, b.tessellation) &&
           same_tessellation(a.mesh.tessellation, b.mesh.tessellation) && a.mesh.out == b.mesh.out &&
           dec(a.preview.normals, b.preview.normals) && a.preview.azimuth == b.preview.azimuth &&
           a.preview.elevation == b.preview.elevation && a.preview.env == b.preview.env &&
           a.preview.boundary == b.preview.boundary;
}

// What an operation needs besides the modifier under test: --mesh its file.
std::string required(const std::string& op)
{
    return op == "mesh" ? ":out=relief-test-mesh.obj" : "";
}

std::vector<float> wavy_normals(int w, int h)
{
    std::vector<float> px(std::size_t(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double gx = 0.3 * std::cos(6.283185307 * 2 * x / w),
                         gy = 0.2 * std::sin(6.283185307 * y / h);
            const double n = std::sqrt(1 + gx * gx + gy * gy);
            float* p = &px[3 * (std::size_t(y) * w + x)];
            p[0] = float(-gx / n);
            p[1] = float(gy / n);  // opengl: the row component is -G
            p[2] = float(1 / n);
        }
    return px;
}

}  // namespace

TEST_CASE("operations: the table lists each operation with its slots and typed modifiers", "[operations]")
{
    std::vector<std::string> names;
    for (const OperationInfo& op : operations())
        names.push_back(op.name);
    CHECK(names == std::vector<std::string>{"slopes", "height", "correct", "bake", "normals", "tessellation",
                                            "mesh", "preview"});
    const OperationInfo* h = find_operation("height");
    REQUIRE(h);
    CHECK(find_operation("frobnicate") == nullptr);
    CHECK(h->inputs.size() == 1);
    CHECK(h->inputs[0].min_channels == 2);
    CHECK(h->inputs[0].max_channels == 4);
    CHECK(find_operation("bake")->inputs.size() == 2);
    for (const OperationInfo& op : operations())
        for (const ModifierInfo& m : op.modifiers) {
            INFO(op.name << ":" << m.name);
            CHECK_FALSE(m.meaning.empty());
            CHECK_FALSE(m.default_value.empty());
            if (m.type == ModifierType::Choice)
                CHECK(m.choices.size() >= 2);
            if (m.type == ModifierType::Integer || m.type == ModifierType::Number)
                CHECK(m.min < m.max);
        }
}

TEST_CASE("operations: defaults are the option structs' own, and each parses back to them", "[operations]")
{
    OperationCall base;
    for (const OperationInfo& op : operations())
        for (const ModifierInfo& m : op.modifiers) {
            INFO(op.name << ":" << m.name << "=" << m.default_value);
            if (m.default_value == "none")
                continue;  // files: nothing to give
            OperationCall parsed;
            REQUIRE(parse_modifiers(parsed, op.name, m.name + "=" + m.default_value + required(op.name)));
            parsed.mesh.out = base.mesh.out;
            if (op.name == "height" && m.applies_to == "method=rays") {
                // a ray modifier selects method=rays; nothing else changes
                CHECK(parsed.height.method == HeightMethod::Rays);
                parsed.height.method = base.height.method;
            }
            CHECK(same_options(parsed, base));
        }
    const auto find = [](const char* op, const char* name) {
        for (const ModifierInfo& m : find_operation(op)->modifiers)
            if (m.name == name)
                return m;
        FAIL("no modifier " << op << ":" << name);
        return ModifierInfo{};
    };
    CHECK(find("height", "rays").default_value == std::to_string(HeightOptions{}.rays));
    CHECK(find("height", "radius").default_value == "64");
    CHECK(find("correct", "theta").default_value == "5");
    CHECK(find("correct", "tolerance").default_value == "2e-05");
    CHECK(find("correct", "polish").default_value == "2");
    CHECK(find("correct", "scale").default_value == "auto");
    CHECK(find("slopes", "max_angle").default_value == "85");
    CHECK(find("bake", "filter").default_value == "bilinear");
}

TEST_CASE("operations: modifier_text writes every modifier, and any change to one changes it",
          "[operations][digest]")
{
    for (const OperationInfo& op : operations()) {
        OperationCall base;
        base.operation = op.name;
        std::string expected;
        for (const ModifierInfo& m : op.modifiers)
            expected += (expected.empty() ? "" : ":") + m.name + "=" + m.default_value;
        CHECK(relief::modifier_text(base) == expected);
        int changed = 0;
        std::string unchanged;
        for (const ModifierInfo& m : op.modifiers) {
            const int before = changed;
            std::vector<std::string> values = m.choices;
            if (m.type == ModifierType::Integer || m.type == ModifierType::Number)
                for (double v : {m.min + 1.0, m.max - 1.0, (m.min + m.max) / 2, m.min + 0.25})
                    values.push_back(m.type == ModifierType::Integer ? std::to_string(long(v))
                                                                     : std::to_string(v));
            if (m.type == ModifierType::File)
                values.push_back(kSampleHeight);
            if (m.type == ModifierType::Output)
                values.push_back("relief-test-mesh.ply");
            if (m.type == ModifierType::Text)
                values.push_back("10,20");
            for (const std::string& v : values) {
                OperationCall c, none;
                const std::string other = m.type == ModifierType::Output ? "" : required(op.name);
                if (!other.empty())
                    parse_modifiers(none, op.name, other.substr(1));
                if (v == m.default_value || !parse_modifiers(c, op.name, m.name + "=" + v + other) ||
                    same_options(c, none))
                    continue;  // needs another modifier with it, or an alias of the default (clip is free)
                c.operation = op.name;
                INFO(op.name << ":" << m.name << "=" << v << " -> " << relief::modifier_text(c));
                // the modifier's own field in the text changed
                const std::string text = ":" + relief::modifier_text(c) + ":";
                CHECK(text.find(":" + m.name + "=" + m.default_value + ":") == std::string::npos);
                CHECK(text.find(":" + m.name + "=") != std::string::npos);
                ++changed;
                break;
            }
            if (changed == before)
                unchanged += " " + m.name;
        }
        INFO(op.name << ": no value tried changes" << unchanged);
        CHECK(changed >= int(op.modifiers.size()) - 1);
    }
    CHECK(relief::implementation_digest().size() == 32);
    CHECK(relief::implementation_digest() == relief::implementation_digest());
}

TEST_CASE("operations: --help and the JSON show every operation and modifier from the table",
          "[operations][cli]")
{
    const std::string help = cli::usage_text();
    const auto json = nlohmann::json::parse(operations_json());
    CHECK(json["abi_version"] == 2);
    REQUIRE(json["operations"].size() == operations().size());
    std::size_t op_at = 0;
    for (const OperationInfo& op : operations()) {
        INFO(op.name);
        const std::size_t at = help.find("Modifiers (:key=value) of --" + op.name + ":");
        REQUIRE(at != std::string::npos);
        CHECK(help.find("--" + op.name + "[:MODS]") != std::string::npos);
        const std::size_t next = help.find("Modifiers (:key=value) of", at + 1);
        const std::string section = help.substr(at, next == std::string::npos ? next : next - at);
        const auto& op_json = json["operations"][op_at++];
        CHECK(op_json["name"] == op.name);
        REQUIRE(op_json["modifiers"].size() == op.modifiers.size());
        std::size_t m_at = 0;
        for (const ModifierInfo& m : op.modifiers) {
            INFO(m.name);
            CHECK(section.find(" " + m.name + "=") != std::string::npos);
            const auto& m_json = op_json["modifiers"][m_at++];
            CHECK(m_json["name"] == m.name);
            CHECK(m_json["default"] == m.default_value);
        }
    }
    CHECK(help.find("rays=J              ray directions per texel; an integer in [1, 4096]") !=
          std::string::npos);
    CHECK(help.find("  with method=rays:\n") != std::string::npos);
    const auto height_op = std::find_if(json["operations"].begin(), json["operations"].end(),
                                        [](const auto& op) { return op["name"] == "height"; });
    REQUIRE(height_op != json["operations"].end());
    const auto& rays = (*height_op)["modifiers"];
    const auto it = std::find_if(rays.begin(), rays.end(), [](const auto& m) { return m["name"] == "rays"; });
    REQUIRE(it != rays.end());
    CHECK((*it)["type"] == "integer");
    CHECK((*it)["choices"].empty());
    CHECK((*it)["min"] == 1);
    CHECK((*it)["max"] == 4096);
}

TEST_CASE("operations: modifier strings parse as on the command line", "[operations][parse]")
{
    OperationCall c;
    REQUIRE(parse_modifiers(c, "correct", "fix=height:0.25:0.5:theta=3"));
    CHECK(c.correct.fix_height == 0.25f);
    CHECK(c.correct.fix_width == 0.5f);
    CHECK(c.correct.theta == 3.0f);
    REQUIRE(parse_modifiers(
        c, "height", std::vector<std::pair<std::string, std::string>>{{"rays", "8"}, {"skip", "off"}}));
    CHECK(c.height.rays == 8);
    CHECK(c.height.method == HeightMethod::Rays);
    CHECK_FALSE(c.height.skip_flat);
    REQUIRE(parse_modifiers(c, "height", ""));
    CHECK(c.height.rays == 32);
    // the ends of the ranges: integers print as integers, floats are checked as stored
    REQUIRE(parse_modifiers(c, "correct", "iterations=1000000:levels=30"));
    CHECK(c.correct.iterations == 1000000);
    REQUIRE(parse_modifiers(c, "height", "rays=4096:radius=65536:phase=0.9999999"));
    CHECK(c.height.phase < 1.0f);
    const struct {
        const char* op;
        const char* mods;
        const char* message;
    } bad[] = {
        {"height", "rays=8:rays=9", "modifier 'rays' given twice"},
        {"height", "rays", "modifier 'rays' is not key=value"},
        {"height", "rays=8:", "modifier '' is not key=value"},
        {"height", "=8", "modifier '=8' is not key=value"},
        {"correct", "fix=height:1", "write fix=height:H0:DH"},
        {"height", "phase=0.99999999", "phase=0.99999999 is 1 in single precision, outside [0, 1)"},
        {"height", "max_angle=89.999999999", "is 90 in single precision, outside (0, 90) degrees"},
        {"height", "radius=1e-50", "radius=1e-50 is 0 in single precision"},
        {"correct", "iterations=2.5", "iterations=2.5 must be an integer in [1, 1000000] or auto"},
        {"correct", "scale=0", "scale=0 is out of range; it must be in (0, 1e+09] or auto"},
        {"bake", "colour=red", "unknown modifier 'colour' (known: filter, colorspace, kind, wrap)"},
        {"warp", "",
         "unknown operation 'warp' (known: slopes, height, correct, bake, normals, tessellation, mesh, "
         "preview)"},
        {"mesh", "patch=8", "a mesh needs a file name (out=FILE.obj|.ply|.gltf|.glb)"},
        {"mesh", "out=m.stl", "unknown mesh format '.stl'"},
        {"mesh", "out=/nonexistent-folder/m.obj", "the folder '/nonexistent-folder' does not exist"},
        {"preview", "light=45", "write light=AZ,EL"},
        {"preview", "light=45,4x", "write light=AZ,EL"},
        {"preview", "light=,45", "write light=AZ,EL"},
        {"preview", "light=45,0", "light=45,0 needs AZ in [-360, 360] degrees and EL in (0, 90] degrees"},
        {"normals", "normal=auto", "normal=auto is not one of opengl|directx"},
        {"tessellation", "patch=0", "patch=0 must be an integer in [1, 4096] texels"},
    };
    for (const auto& b : bad) {
        INFO(b.op << ":" << b.mods);
        OperationCall k;
        CHECK_FALSE(parse_modifiers(k, b.op, b.mods));
        const std::string e = geterror();
        INFO(e);
        CHECK(e.find(b.message) != std::string::npos);
    }
}

TEST_CASE("operations: the API refuses what the parser refuses, with the same words", "[operations][errors]")
{
    const ImageBuf n = test::image(16, 16, 3, wavy_normals(16, 16));
    for (const char* mods : {"rays=0", "rays=5000", "radius=0", "phase=1", "max_angle=90", "highpass=-1"}) {
        INFO(mods);
        OperationCall parsed;
        CHECK_FALSE(parse_modifiers(parsed, "height", mods));
        const std::string from_parser = geterror();
        // the same value through the C++ option struct
        HeightOptions o;
        const std::string m = mods;
        const double v = std::atof(m.substr(m.find('=') + 1).c_str());
        if (m.rfind("rays", 0) == 0)
            o.rays = int(v);
        if (m.rfind("radius", 0) == 0)
            o.radius = float(v);
        if (m.rfind("phase", 0) == 0)
            o.phase = float(v);
        if (m.rfind("max_angle", 0) == 0)
            o.normals.max_angle = float(v);
        if (m.rfind("highpass", 0) == 0)
            o.highpass = float(v);
        ImageBuf out;
        CHECK_FALSE(relief::height(out, n, o));
        CHECK(geterror() == "height: " + from_parser);
    }
}

TEST_CASE("operations: run_operation reads mask and fix files and equals the direct calls",
          "[operations][mask]")
{
    const int w = 64, h = 64;
    const ImageBuf n = test::image(w, h, 3, wavy_normals(w, h));
    std::vector<float> mw(std::size_t(w) * h, 1.0f);
    for (int y = 20; y < 30; ++y)
        for (int x = 10; x < 40; ++x)
            mw[std::size_t(y) * w + x] = 0.0f;
    const ImageBuf mask = test::image(w, h, 1, mw);
    const std::string dir = std::string(RELIEF_TEST_TMP) + "/operations";
    std::filesystem::create_directories(dir);
    const std::string mask_file = dir + "/mask.exr";
    REQUIRE(write_image(mask, mask_file));

    HeightOptions direct;
    direct.normals.convention = NormalConvention::OpenGL;
    direct.mask = &mask;
    const ImageBuf expected = relief::height(n, direct);
    REQUIRE_FALSE(expected.has_error());

    OperationCall call;
    REQUIRE(parse_modifiers(call, "height", "normal=opengl:mask=" + mask_file));
    CHECK(call.mask_file == mask_file);
    ImageBuf got;
    REQUIRE(run_operation(got, call, {&n}));
    CHECK(test::pixels(got) == test::pixels(expected));
    // `op` with `modifiers` on `in` through the table: its pixels.
    const auto table_run = [](const char* op, const std::string& modifiers, const ImageBuf& in) {
        OperationCall c;
        REQUIRE(parse_modifiers(c, op, modifiers));
        ImageBuf out;
        REQUIRE(run_operation(out, c, {&in}));
        return test::pixels(out);
    };
    CHECK(table_run("height", "normal=opengl", n) != test::pixels(expected));  // the mask mattered

    // fix=FILE the same way, on relief's own height (scale implied)
    const ImageBuf& height = expected;
    CorrectOptions co;
    co.levels = 1;
    co.iterations = 3;
    co.fix_mask = &mask;
    const ImageBuf fixed = relief::correct(height, co);
    REQUIRE_FALSE(fixed.has_error());
    CHECK(table_run("correct", "levels=1:iterations=3:fix=" + mask_file, height) == test::pixels(fixed));
    CHECK(table_run("correct", "levels=1:iterations=3", height) != test::pixels(fixed));

    // a mask file that is not there by the time it runs
    OperationCall gone = call;
    gone.mask_file = dir + "/gone.exr";
    CHECK_FALSE(run_operation(got, gone, {&n}));
    CHECK(geterror().rfind("mask: ", 0) == 0);
}

TEST_CASE("operations: run_operation checks its inputs and takes the execution given", "[operations][errors]")
{
    const ImageBuf n = test::image(8, 8, 3, wavy_normals(8, 8));
    OperationCall call;
    REQUIRE(parse_modifiers(call, "bake", ""));
    ImageBuf out;
    CHECK_FALSE(run_operation(out, call, {&n}));
    CHECK(geterror() == "bake takes 2 image(s), got 1");
    CHECK_FALSE(run_operation(out, call, {&n, nullptr}));
    CHECK(geterror().find("missing") != std::string::npos);
    const ImageBuf gray = test::image(8, 8, 1, std::vector<float>(64, 0.5f));
    REQUIRE(parse_modifiers(call, "height", ""));
    CHECK_FALSE(run_operation(out, call, {&gray}));
    CHECK(geterror().find("height: unsupported channel count 1") == 0);
    // The API takes the top of a range the parser takes: it fails later, on the fixation mask.
    const ImageBuf wide = test::image(9, 8, 1, std::vector<float>(72, 1.0f));
    CorrectOptions top;
    top.scale = 0.1f;
    top.iterations = 1000000;
    top.levels = 30;
    top.fix_mask = &wide;
    ImageBuf off;
    CHECK_FALSE(relief::correct(off, gray, top));
    CHECK(geterror().find("the fixation mask is 9x8") != std::string::npos);
    REQUIRE(parse_modifiers(call, "height", "normal=opengl"));
    Execution exec;
    exec.device = "9:9";
    CHECK_FALSE(run_operation(out, call, {&n}, exec));
    CHECK(geterror().find("9:9") != std::string::npos);
    std::string said;
    exec.device = "auto";
    exec.on_message = [&](Severity, const std::string& m) { said += m + "\n"; };
    REQUIRE(run_operation(out, call, {&n}, exec));
    CHECK(said.find("boundary:") != std::string::npos);
}

TEST_CASE("C ABI: a result carries every relief:* attribute of the API's result, and reads back as input",
          "[operations][abi]")
{
    const int w = 24, h = 20;
    std::vector<float> normals = wavy_normals(w, h);
    std::vector<float> texture(std::size_t(w) * h * 3);
    for (std::size_t i = 0; i < texture.size(); ++i)
        texture[i] = float((i * 37) % 101) / 100.0f;
    // The relief:* attributes of an API result, as the C ABI writes them.
    const auto attributes = [](const ImageBuf& img) {
        std::string text;
        for (const auto& p : img.spec().extra_attribs)
            if (p.name().string().rfind("relief:", 0) == 0)
                text += p.name().string() + "=" + p.get_string() + "\n";
        return text;
    };
    // op(modifiers) through the API and through relief_run, on the same
    // pixels and (C) metadata: the same pixels and attributes.
    const auto both = [&](const std::string& op, const std::string& mods, std::vector<const ImageBuf*> api_in,
                          std::vector<relief_image> c_in) {
        INFO(op << " " << mods);
        OperationCall call;
        REQUIRE(parse_modifiers(call, op, mods));
        ImageBuf expected;
        REQUIRE(run_operation(expected, call, api_in));
        relief_image got{};
        REQUIRE(relief_run(op.c_str(), mods.c_str(), c_in.data(), int(c_in.size()), &got) == RELIEF_OK);
        CHECK(got.width == expected.spec().width);
        CHECK(got.height == expected.spec().height);
        CHECK(got.channels == expected.spec().nchannels);
        const std::vector<float> px(static_cast<const float*>(got.pixels),
                                    static_cast<const float*>(got.pixels) +
                                        std::size_t(got.width) * got.height * got.channels);
        CHECK(px == test::pixels(expected));
        const std::string text = got.metadata ? got.metadata : "(null)";
        CHECK(text == attributes(expected));
        return std::make_pair(got, expected);
    };
    const ImageBuf n = test::image(w, h, 3, normals);
    const relief_image cn = {w, h, 3, RELIEF_FLOAT, normals.data(), nullptr};

    auto [ch, height] = both("height", "normal=opengl:boundary=free", {&n}, {cn});
    // height says how it was made: method, parameters, convention, unit
    for (const char* key :
         {"relief:method=", "relief:parameters=", "relief:normal_convention=", "relief:height_unit="})
        CHECK(("\n" + std::string(ch.metadata)).find(std::string("\n") + key) != std::string::npos);
    relief_image_free(&ch);
    for (const char* mods : {"normal=directx:method=rays:rays=8:radius=8", "normal=opengl:highpass=4"}) {
        auto [c, a] = both("height", mods, {&n}, {cn});
        relief_image_free(&c);
    }
    auto [cs, slopes] = both("slopes", "normal=opengl", {&n}, {cn});
    relief_image_free(&cs);

    // correct's scale=auto reads the height's metadata: the C side gets it
    // from the text it was given, the API from the image.
    std::vector<float> hp = test::pixels(height);
    relief_image chin = {w, h, 1, RELIEF_FLOAT, hp.data(), nullptr};
    const std::string meta = attributes(height);
    chin.metadata = const_cast<char*>(meta.c_str());
    auto [coff, off] = both("correct", "levels=1:iterations=3", {&height}, {chin});
    CHECK(std::string(coff.metadata).find("relief:scale=") != std::string::npos);
    relief_image_free(&coff);
    for (const char* op : {"normals", "tessellation"}) {
        auto [c, a] = both(op, "", {&height}, {chin});
        relief_image_free(&c);
    }
    auto [cp, sheet] = both("preview", "normal=opengl", {&n, &height}, {cn, chin});
    relief_image_free(&cp);

    const ImageBuf tex = test::image(w, h, 3, texture);
    std::vector<float> op = test::pixels(off);
    std::string off_meta = attributes(off);
    relief_image ctex = {w, h, 3, RELIEF_FLOAT, texture.data(), nullptr},
                 coffin = {w, h, 2, RELIEF_FLOAT, op.data(), off_meta.data()};
    auto [cb, baked] = both("bake", "kind=data", {&tex, &off}, {ctex, coffin});
    relief_image_free(&cb);
}

namespace {

// What a host's relief_callbacks heard.
struct Heard {
    std::vector<std::pair<int, std::string>> messages;
    std::vector<double> progress;
    int cancel_at = 0;  // the progress call (1, 2, ...) that answers non-zero; 0: none
};

void heard_message(int severity, const char* text, void* user)
{
    static_cast<Heard*>(user)->messages.emplace_back(severity, text);
}

// Messages as "severity: text" lines, for a failure to show; times in
// seconds (one run's own) as "#".
std::string lines_of(const std::vector<std::pair<int, std::string>>& messages)
{
    std::string s;
    for (const auto& [severity, text] : messages)
        s += std::to_string(severity) + ": " +
             std::regex_replace(text, std::regex(R"(\d+\.\d+ s\b)"), "# s") + "\n";
    return s;
}

// `fractions` without a fraction repeated at once.
std::vector<double> distinct(std::vector<double> fractions)
{
    fractions.erase(std::unique(fractions.begin(), fractions.end()), fractions.end());
    return fractions;
}

int heard_progress(double fraction, void* user)
{
    Heard& h = *static_cast<Heard*>(user);
    h.progress.push_back(fraction);
    return int(h.progress.size()) == h.cancel_at;
}

}  // namespace

TEST_CASE("C ABI: a call without its images is refused, saying how many the operation takes",
          "[operations][abi]")
{
    std::vector<float> normals = wavy_normals(8, 8);
    const relief_image in = {8, 8, 3, RELIEF_FLOAT, normals.data(), nullptr};
    for (const bool null_array : {false, true}) {
        INFO((null_array ? "inputs NULL, n_inputs 1" : "n_inputs 0"));
        relief_image out = {1, 1, 1, RELIEF_FLOAT, nullptr, nullptr};
        CHECK(relief_run("height", "", null_array ? nullptr : &in, null_array ? 1 : 0, &out) ==
              RELIEF_INVALID);
        CHECK(std::string(relief_last_error()).find("height takes 1 image(s), got 0") != std::string::npos);
        CHECK((out.width == 0 && out.pixels == nullptr));
    }
}

TEST_CASE("C ABI: a NULL or empty device is auto, as relief_run", "[operations][abi]")
{
    std::vector<float> normals = wavy_normals(16, 16);
    const relief_image in = {16, 16, 3, RELIEF_FLOAT, normals.data(), nullptr};
    relief_image automatic{}, null_device{}, empty_device{}, with_null{};
    REQUIRE(relief_run("height", "normal=opengl", &in, 1, &automatic) == RELIEF_OK);
    CHECK(relief_run_on(nullptr, "height", "normal=opengl", &in, 1, &null_device) == RELIEF_OK);
    CHECK(relief_run_on("", "height", "normal=opengl", &in, 1, &empty_device) == RELIEF_OK);
    CHECK(relief_run_with(nullptr, "height", "normal=opengl", &in, 1, &with_null, nullptr) == RELIEF_OK);
    const auto pixels = [](const relief_image& i) {
        return i.pixels ? std::vector<float>(static_cast<const float*>(i.pixels),
                                             static_cast<const float*>(i.pixels) + 16 * 16)
                        : std::vector<float>();
    };
    CHECK(pixels(null_device) == pixels(automatic));
    CHECK(pixels(empty_device) == pixels(automatic));
    CHECK(pixels(with_null) == pixels(automatic));
    relief_image tiles_out[1] = {};
    const int tile = 1001;
    CHECK(relief_run_tiles(nullptr, "height", "normal=opengl", &tile, &in, 1, tiles_out) == RELIEF_OK);
    CHECK(pixels(tiles_out[0]) == pixels(automatic));
    for (relief_image* i : {&automatic, &null_device, &empty_device, &with_null, &tiles_out[0]})
        relief_image_free(i);
}

TEST_CASE("C ABI: metadata is lines of name=value, the last one read without its newline",
          "[operations][abi]")
{
    // A height in texels (relief:height_unit=texel) needs no scale for the
    // correction; without the unit it does.
    const int n = 16;
    std::vector<float> hts = test::waves(n, n, 2.0, 5);
    relief_image h = {n, n, 1, RELIEF_FLOAT, hts.data(), nullptr};
    relief_image out{};
    CHECK(relief_run("correct", "levels=1:iterations=1", &h, 1, &out) == RELIEF_FAILED);
    CHECK(std::string(relief_last_error()).find("scale") != std::string::npos);
    for (const char* metadata : {"relief:height_unit=texel", "=x\nrelief:height_unit=texel",
                                 "relief:x\nrelief:height_unit=texel\n"}) {
        INFO(metadata);
        std::string text = metadata;
        h.metadata = text.data();
        REQUIRE(relief_run("correct", "levels=1:iterations=1", &h, 1, &out) == RELIEF_OK);
        CHECK((out.width == n && out.height == n));
        relief_image_free(&out);
    }
}

TEST_CASE("height reports progress by stage: the slopes, the boundary, the integration (the rays' within "
          "it), the end",
          "[operations]")
{
    const int w = 64, h = 48;
    const ImageBuf n = test::image(w, h, 3, wavy_normals(w, h));
    for (const char* mods : {"normal=opengl", "normal=opengl:method=rays:rays=8:radius=8"}) {
        INFO(mods);
        OperationCall call;
        REQUIRE(parse_modifiers(call, "height", mods));
        std::vector<double> said;
        Execution exec;
        exec.on_progress = [&](double f) { said.push_back(f); };
        ImageBuf out;
        REQUIRE(run_operation(out, call, {&n}, exec));
        REQUIRE(said.size() >= 5);
        CHECK(said == [&] {
            std::vector<double> s = said;
            std::sort(s.begin(), s.end());
            return s;
        }());
        CHECK(std::vector<double>(said.begin(), said.begin() + 3) == std::vector<double>{0.0, 0.2, 0.35});
        CHECK(std::vector<double>(said.end() - 2, said.end()) == std::vector<double>{0.9, 1.0});
        if (std::string(mods).find("rays") != std::string::npos)
            CHECK(said.size() > 6);  // the rays' own steps, inside [0.35, 0.9]
    }
}

TEST_CASE("C ABI and C++: relief called again from its own callbacks is refused at once, the outer call "
          "unharmed",
          "[operations][abi][errors]")
{
    const int w = 32, h = 24;
    std::vector<float> normals = wavy_normals(w, h);
    const relief_image cn = {w, h, 3, RELIEF_FLOAT, normals.data(), nullptr};
    struct Host {
        const relief_image* in = nullptr;
        int inner_calls = 0, inner_invalid = 0;
        std::string inner_error;
        std::string error_heard;
    } host;
    host.in = &cn;
    // From progress, in a correction (which reports as it goes) and a height.
    relief_callbacks from_progress{};
    from_progress.user = &host;
    from_progress.progress = [](double, void* user) -> int {
        auto& hs = *static_cast<Host*>(user);
        relief_image again{};
        ++hs.inner_calls;
        if (relief_run("height", "normal=opengl", hs.in, 1, &again) == RELIEF_INVALID)
            ++hs.inner_invalid;
        hs.inner_error = relief_last_error();
        relief_image_free(&again);
        return 0;
    };
    std::vector<float> hts = test::waves(w, h, 2.0, 5);
    const relief_image ch = {w, h, 1, RELIEF_FLOAT, hts.data(), nullptr};
    for (const auto& [op, in] : {std::pair{"height", &cn}, std::pair{"correct", &ch}}) {
        INFO(op);
        host = Host{};
        host.in = &cn;
        relief_image out{};
        const std::string mods = op == std::string("height") ? "normal=opengl" : "scale=0.2:levels=2";
        CHECK(relief_run_with("auto", op, mods.c_str(), in, 1, &out, &from_progress) == RELIEF_OK);
        CHECK(out.pixels != nullptr);
        relief_image_free(&out);
        CHECK(host.inner_calls >= 2);
        CHECK(host.inner_invalid == host.inner_calls);
        CHECK(host.inner_error.find("called from inside a message, progress or cancel callback") !=
              std::string::npos);
    }
    // From the message callback as it hears the outer call's failure: the
    // outer error is what relief_last_error() says afterwards.
    relief_callbacks from_message{};
    from_message.user = &host;
    from_message.message = [](int severity, const char* text, void* user) {
        auto& hs = *static_cast<Host*>(user);
        if (severity != RELIEF_ERROR)
            return;
        hs.error_heard = text;
        relief_image again{};
        ++hs.inner_calls;
        if (relief_run("height", "normal=opengl", hs.in, 1, &again) == RELIEF_INVALID)
            ++hs.inner_invalid;
        relief_image_free(&again);
    };
    host = Host{};
    host.in = &cn;
    relief_image out{};
    CHECK(relief_run_with("9:9", "height", "", &cn, 1, &out, &from_message) == RELIEF_FAILED);
    CHECK(host.inner_calls == 1);
    CHECK(host.inner_invalid == 1);
    CHECK(std::string(relief_last_error()).find("9:9") != std::string::npos);
    CHECK(relief_last_error() == host.error_heard);

    // C++: an operation started from a callback fails at once, saying why.
    std::string inner;
    int progress_calls = 0;
    const ImageBuf n = test::image(w, h, 3, normals);
    Execution exec;
    exec.on_progress = [&](double) {
        ++progress_calls;
        inner = relief::height(n, HeightOptions{}).geterror();
    };
    OperationCall call;
    REQUIRE(parse_modifiers(call, "height", "normal=opengl:method=rays:rays=8:radius=8"));
    ImageBuf result;
    CHECK(run_operation(result, call, {&n}, exec));
    CHECK(progress_calls >= 2);
    CHECK(inner.find("called from inside a message, progress or cancel callback") != std::string::npos);
    // ... and from its cancel, asked before each kernel, through the API's
    // own function as through the table.
    int cancel_calls = 0;
    inner.clear();
    HeightOptions asks;
    asks.exec.cancel = [&] {
        if (cancel_calls++ == 0)
            inner = relief::height(n, HeightOptions{}).geterror();
        return false;
    };
    CHECK(relief::height(n, asks).geterror().empty());
    CHECK(cancel_calls >= 2);
    CHECK(inner.find("called from inside a message, progress or cancel callback") != std::string::npos);
    // Outside callbacks, the same thread calls freely again.
    CHECK(relief::height(n, HeightOptions{}).spec().width == w);
}

TEST_CASE("C ABI: relief_run_with tells the API's messages at their severity, its progress, and stops at a "
          "cancel",
          "[operations][abi]")
{
    // Float normals with a texel of zero length (a warning), an unknown
    // convention (auto: a notice) and details (info).
    const int w = 48, h = 40;
    std::vector<float> normals = wavy_normals(w, h);
    normals[3 * (5 * w + 7) + 0] = normals[3 * (5 * w + 7) + 1] = normals[3 * (5 * w + 7) + 2] = 0.0f;
    const ImageBuf n = test::image(w, h, 3, normals);
    const relief_image cn = {w, h, 3, RELIEF_FLOAT, normals.data(), nullptr};
    for (const char* op : {"height", "correct"}) {
        INFO(op);
        // height's boundary=auto: a notice of the boundary it found
        const std::string mods = op == std::string("height") ? "" : "scale=0.2:levels=2";
        OperationCall call;
        REQUIRE(parse_modifiers(call, "height", "boundary=free"));
        ImageBuf heights;
        REQUIRE(run_operation(heights, call, {&n}));
        std::vector<float> hp = test::pixels(heights);
        const relief_image ch = {w, h, 1, RELIEF_FLOAT, hp.data(), nullptr};
        const bool is_height = op == std::string("height");
        // the API's messages and progress, with the C severities
        std::vector<std::pair<int, std::string>> said;
        std::vector<double> done;
        Execution exec;
        exec.on_message = [&](Severity s, const std::string& text) {
            const int c = s == Severity::Debug    ? RELIEF_DEBUG
                          : s == Severity::Info   ? RELIEF_INFO
                          : s == Severity::Notice ? RELIEF_NOTICE
                                                  : RELIEF_WARNING;
            said.emplace_back(c, text);
        };
        exec.on_progress = [&](double f) { done.push_back(f); };
        OperationCall op_call;
        REQUIRE(parse_modifiers(op_call, op, mods));
        ImageBuf api;
        REQUIRE(run_operation(api, op_call, {is_height ? &n : &heights}, exec));
        Heard heard;
        relief_callbacks cb = {heard_message, heard_progress, &heard};
        relief_image out{};
        REQUIRE(relief_run_with("auto", op, mods.c_str(), is_height ? &cn : &ch, 1, &out, &cb) == RELIEF_OK);
        CHECK(lines_of(heard.messages) == lines_of(said));
        // (either may hear a fraction again: the heartbeat, detail::paced)
        CHECK(distinct(heard.progress) == distinct(done));
        CHECK(std::vector<float>(static_cast<const float*>(out.pixels),
                                 static_cast<const float*>(out.pixels) +
                                     std::size_t(out.width) * out.height * out.channels) ==
              test::pixels(api));
        relief_image_free(&out);
        if (is_height) {
            const auto has = [&](int severity, const std::string& text) {
                for (const auto& [s, t] : heard.messages)
                    if (s == severity && t.find(text) != std::string::npos)
                        return true;
                return false;
            };
            CHECK(has(RELIEF_WARNING, "1 texel(s) had NaN, infinite, zero-length or downward normals"));
            CHECK(has(RELIEF_NOTICE, "boundary: "));
            CHECK(has(RELIEF_INFO, "device"));
        }
        REQUIRE(done.size() >= (is_height ? 2 : 3));
        // a non-zero answer at a report before the last (height's first,
        // before any work): no report after it, no image, why told once as
        // an error
        Heard stop;
        stop.cancel_at = is_height ? 1 : 2;
        relief_callbacks cancel = {heard_message, heard_progress, &stop};
        relief_image never;
        std::memset(&never, 0x5a, sizeof never);
        CHECK(relief_run_with("auto", op, mods.c_str(), is_height ? &cn : &ch, 1, &never, &cancel) ==
              RELIEF_CANCELLED);
        CHECK(int(stop.progress.size()) == stop.cancel_at);
        CHECK((never.pixels == nullptr && never.metadata == nullptr && never.width == 0));
        CHECK(std::string(relief_last_error()) == std::string(op) + ": cancelled");
        REQUIRE(!stop.messages.empty());
        CHECK(stop.messages.back() == std::make_pair(int(RELIEF_ERROR), std::string(relief_last_error())));
        int errors = 0;
        for (const auto& m : stop.messages)
            errors += m.first == RELIEF_ERROR;
        CHECK(errors == 1);
    }
    // a refusal: RELIEF_INVALID, told once as an error, no progress
    Heard refused;
    relief_callbacks cb = {heard_message, heard_progress, &refused};
    relief_image out;
    CHECK(relief_run_with("auto", "height", "rays=-3", &cn, 1, &out, &cb) == RELIEF_INVALID);
    REQUIRE(refused.messages.size() == 1);
    CHECK(refused.messages[0] == std::make_pair(int(RELIEF_ERROR), std::string(relief_last_error())));
    CHECK(refused.messages[0].second.find("rays=-3") != std::string::npos);
    CHECK(refused.progress.empty());
    // messages without progress: nothing asks to cancel, nothing reported
    Heard quiet;
    relief_callbacks only_messages = {heard_message, nullptr, &quiet};
    REQUIRE(relief_run_with("auto", "height", "boundary=free", &cn, 1, &out, &only_messages) == RELIEF_OK);
    CHECK(!quiet.messages.empty());
    CHECK(quiet.progress.empty());
    relief_image_free(&out);
}

TEST_CASE("prepare: set-up ahead, beside a running height, changes nothing but the time",
          "[operations][prepare][slow]")
{
    // sizes no other test plans, so that prepare() really plans them here
    const int w = 70, h = 54;
    const ImageBuf n = test::image(w, h, 3, wavy_normals(w, h));
    HeightOptions periodic;
    periodic.boundary = Boundary::Periodic;
    HeightOptions free_edges;
    free_edges.boundary = Boundary::Free;
    const ImageBuf before_p = relief::height(n, periodic), before_f = relief::height(n, free_edges);
    const relief::SetupTimes t0 = relief::setup_times();
    // beside the operations, over and over: no crash, the same bits
    for (int round = 0; round < 3; ++round) {
        auto ahead = std::async(std::launch::async, [&] { relief::prepare("auto", w + round, h); });
        CHECK(test::pixels(relief::height(n, free_edges)) == test::pixels(before_f));
        CHECK(test::pixels(relief::height(n, periodic)) == test::pixels(before_p));
        ahead.wait();
    }
    const relief::SetupTimes t1 = relief::setup_times();
    CHECK(t1.prepared > t0.prepared);  // its time is counted apart
    // prepared sizes are then found ready: a height of 72 x 54 plans nothing
    relief::prepare("auto", w + 2, h);
    const double plans = relief::setup_times().plans;
    const ImageBuf m = test::image(w + 2, h, 3, wavy_normals(w + 2, h));
    CHECK(relief::height(m, free_edges).initialized());
    CHECK(relief::setup_times().plans - plans < 0.01);
    // problems are left to the operation: prepare() sets no error (the read
    // first clears what an earlier test on this thread left, e.g. a preview
    // without its font on a machine that lacks fonts-dejavu-core)
    relief::geterror();
    relief::prepare("9:9", 64, 64);
    relief::prepare("auto", 0, -3);
    CHECK(relief::geterror().empty());
}

TEST_CASE("operations: what a front end asks of a call, answered by the table without its name",
          "[operations][parse]")
{
    const std::string dir = std::string(RELIEF_TEST_TMP) + "/operations";
    std::filesystem::create_directories(dir);
    const std::string file = dir + "/weights.exr";
    REQUIRE(write_image(test::image(4, 4, 1, std::vector<float>(16, 1.0f)), file));
    const auto call = [](const std::string& op, const std::string& mods) {
        OperationCall c;
        REQUIRE(parse_modifiers(c, op, mods));
        return c;
    };
    using V = std::vector<std::string>;
    // files read: paths only, not the words (alpha, none, sky, height:H0:DH)
    CHECK(files_read(call("height", "mask=" + file)) == V{file});
    CHECK(files_read(call("height", "mask=alpha")).empty());
    CHECK(files_read(call("height", "")).empty());
    CHECK(files_read(call("correct", "fix=" + file)) == V{file});
    CHECK(files_read(call("correct", "fix=height:0:1")).empty());
    CHECK(files_read(call("preview", "env=" + file)) == V{file});
    CHECK(files_read(call("preview", "env=sky")).empty());
    // an image given in memory is no file
    OperationCall in_memory = call("height", "");
    const ImageBuf weights = test::image(4, 4, 1, std::vector<float>(16, 1.0f));
    in_memory.height.mask = &weights;
    CHECK(files_read(in_memory).empty());
    // files written besides the result: mesh's out=
    CHECK(files_written(call("mesh", "out=" + dir + "/m.obj")) == V{dir + "/m.obj"});
    for (const char* op : {"slopes", "height", "correct", "normals", "tessellation"})
        CHECK(files_written(call(op, "")).empty());
    // set-up ahead: Poisson's plans depend on the size only; rays' do not
    CHECK(sets_up_ahead(call("height", "")));
    CHECK(sets_up_ahead(call("height", "method=poisson:boundary=free")));
    CHECK_FALSE(sets_up_ahead(call("height", "method=rays")));
    CHECK_FALSE(sets_up_ahead(call("slopes", "")));
    CHECK_FALSE(sets_up_ahead(call("correct", "")));
    // -v's description: what height resolves, nothing for the others
    CHECK(describe(call("height", "method=rays:rays=16")) ==
          describe(call("height", "method=rays:rays=16").height));
    CHECK_FALSE(describe(call("height", "")).empty());
    CHECK(describe(call("slopes", "")).empty());
    // and the parameters a height records: a mask is said, by its kind
    HeightOptions alpha, image;
    alpha.mask_alpha = true;
    image.mask = &weights;
    CHECK(describe(alpha) == "method=auto boundary=auto highpass=0 mask=alpha");
    CHECK(describe(image) == "method=auto boundary=auto highpass=0 mask=image");
    CHECK(describe(HeightOptions{}) == "method=auto boundary=auto highpass=0");
    // reports: the two operations that have one, under their own names
    V reporting;
    for (const OperationInfo& op : operations())
        if (!op.report.empty())
            reporting.push_back(op.name + "=" + op.report);
    CHECK(reporting == V{"height=height", "correct=correct"});
    OperationCall unknown;
    unknown.operation = "nonesuch";
    CHECK(files_read(unknown).empty());
    CHECK_FALSE(sets_up_ahead(unknown));
}

TEST_CASE("validate: a rule reads the same from validate(), the modifiers and the operation itself",
          "[operations][errors]")
{
    // Each rule once, in one wording: the table (command line, C ABI,
    // Python) and the C++ API reach the same validate().
    struct Case {
        const char* operation;
        const char* modifiers;
        std::function<void(OperationCall&)> set;
        const char* message;
    };
    const Case cases[] = {
        {"height", "phase=1", [](OperationCall& c) { c.height.phase = 1.0f; },
         "phase=1 is out of range; it must be in [0, 1)"},
        {"height", "rays=0", [](OperationCall& c) { c.height.rays = 0; },
         "rays=0 must be an integer in [1, 4096]"},
        {"height", "max_angle=90", [](OperationCall& c) { c.height.normals.max_angle = 90.0f; },
         "max_angle=90 is out of range; it must be in (0, 90) degrees"},
        {"height", "method=rays:directions=exact",
         [](OperationCall& c) {
             c.height.method = HeightMethod::Rays;
             c.height.directions = RayDirections::Exact;
         },
         "impl=fast needs directions=rational (or use impl=reference)"},
        {"height", "highpass=8:mask=alpha",
         [](OperationCall& c) {
             c.height.highpass = 8.0f;
             c.height.mask_alpha = true;
         },
         "highpass cannot be combined with a mask yet"},
        {"height", "method=rays:boundary=periodic,free",
         [](OperationCall& c) {
             c.height.method = HeightMethod::Rays;
             c.height.boundary = {Boundary::Periodic, Boundary::Free};
         },
         "rays take one boundary for both axes (periodic, clip or auto); a boundary per axis needs "
         "method=poisson"},
        {"height", "rays=8:highpass=4",
         [](OperationCall& c) {
             c.height.method = HeightMethod::Rays;
             c.height.highpass = 4.0f;
         },
         "highpass applies to method=poisson, not to rays"},
        {"correct", "theta=21", [](OperationCall& c) { c.correct.theta = 21.0f; },
         "theta=21 is out of range; it must be in [0, 20]"},
        {"correct", "levels=31", [](OperationCall& c) { c.correct.levels = 31; },
         "levels=31 must be an integer in [1, 30] or auto"},
        {"correct", "relax=2", [](OperationCall& c) { c.correct.relax = 2.0f; },
         "relax=2 is out of range; it must be in [1, 2)"},
        {"correct", "polish=-1", [](OperationCall& c) { c.correct.polish = -1; },
         "polish=-1 must be an integer in [0, 1000]"},
        {"normals", "scale=0", [](OperationCall& c) { c.normals.scale = 0.0f; },
         "scale=0 is out of range; it must be in (0, 1e+09]"},
        {"tessellation", "patch=0", [](OperationCall& c) { c.tessellation.patch = 0; },
         "patch=0 must be an integer in [1, 4096] texels"},
        {"mesh", "error=0", [](OperationCall& c) { c.mesh.tessellation.error = 0.0f; },
         "error=0 is out of range; it must be in (0, 1e+09] texels x S"},
        {"mesh", "patch=8", [](OperationCall&) {}, "a mesh needs a file name (out=FILE.obj|.ply|.gltf|.glb)"},
        {"preview", "light=400,45", [](OperationCall& c) { c.preview.azimuth = 400.0f; },
         "light=400,45 needs AZ in [-360, 360] degrees and EL in (0, 90] degrees"},
        {"correct", "fix=height:1:1e35",
         [](OperationCall& c) {
             c.correct.fix_height = 1.0f;
             c.correct.fix_width = 1e35f;
         },
         "fix width=1e+35 is out of range; it must be in (0, 1e+30] or none"},
        {"normals", "normal=auto", [](OperationCall& c) { c.normals.convention = NormalConvention::Auto; },
         "normal=auto is not one of opengl|directx"},
        {"slopes", "max_angle=0", [](OperationCall& c) { c.slopes.normals.max_angle = 0.0f; },
         "max_angle=0 is out of range; it must be in (0, 90) degrees"},
    };
    const auto validated = [](const OperationCall& c) {
        const std::string& op = c.operation;
        return op == "height"         ? validate(c.height)
               : op == "correct"      ? validate(c.correct)
               : op == "normals"      ? validate(c.normals)
               : op == "tessellation" ? validate(c.tessellation)
               : op == "mesh"         ? validate(c.mesh)
               : op == "preview"      ? validate(c.preview)
                                      : validate(c.slopes);
    };
    const ImageBuf flat = test::image(8, 8, 3, std::vector<float>(8 * 8 * 3, 0.5f));
    for (const Case& c : cases) {
        INFO(c.operation << ":" << c.modifiers);
        OperationCall parsed;
        CHECK_FALSE(parse_modifiers(parsed, c.operation, c.modifiers));
        CHECK(geterror() == c.message);
        OperationCall direct;
        direct.operation = c.operation;
        c.set(direct);
        CHECK(validated(direct) == c.message);
        // The operation refuses the options before it looks at the image.
        ImageBuf dst;
        std::vector<const ImageBuf*> in(find_operation(c.operation)->inputs.size(), &flat);
        CHECK_FALSE(run_operation(dst, direct, in));
        CHECK(geterror() == std::string(c.operation) + ": " + c.message);
    }
    // A mask file is read only when the call runs, yet its rules hold at parse.
    OperationCall masked;
    CHECK_FALSE(parse_modifiers(masked, "height", "rays=8:mask=" + kSampleHeight));
    CHECK(geterror() == "a mask applies to method=poisson, not to rays");
    CHECK(parse_modifiers(masked, "height", "mask=" + kSampleHeight));
    // Enum values that C++ casts can make and no modifier can: refused with their number.
    HeightOptions cast;
    cast.method = static_cast<HeightMethod>(7);
    CHECK(validate(cast) == "method=7 is not one of auto|rays|poisson");
    CorrectOptions search;
    search.search = static_cast<CorrectSearch>(-1);
    CHECK(validate(search) == "search=-1 is not one of brent|golden|ternary");
    BakeOptions bake;
    bake.wrap = static_cast<BakeWrap>(3);
    CHECK(validate(bake) == "wrap=3 is not one of auto|periodic|clamp");
    SlopeOptions slopes;
    slopes.normals.float_encoding = static_cast<FloatEncoding>(2);
    CHECK(validate(slopes) == "range=2 is not one of signed|unsigned");
    // The defaults are valid, and so are words standing for 0 (auto).
    OperationCall defaults;
    CHECK(validate(defaults.height).empty());
    CHECK(validate(defaults.correct).empty());
    CHECK(validate(defaults.preview).empty());
    CHECK(validate(defaults.tessellation).empty());
    defaults.correct.levels = 0;
    defaults.correct.iterations = 0;
    CHECK(validate(defaults.correct).empty());
    defaults.correct.iterations = -1;
    CHECK(validate(defaults.correct) == "iterations=-1 must be an integer in [1, 1000000] or auto");
}
