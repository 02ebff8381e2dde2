// SPDX-License-Identifier: Apache-2.0
// The command-line parser: every modifier and option lands in the field it
// names, with the value given; nothing given means the API's defaults,
// which are the documented ones (README, --help).
#include <catch2/catch.hpp>

#include <filesystem>
#include <functional>

#include "command_line.h"
#include "support/images.h"

using namespace relief;
using relief::cli::parse_command_line;
using relief::cli::Program;
using relief::cli::Step;
using relief::cli::UsageError;

using relief::test::kSampleHeight;
using relief::test::kSampleNormal;

namespace {

// Parses `in --command:mods` and returns the command's step.
Step step_of(const std::string& command)
{
    const Program p = parse_command_line({kSampleNormal, kSampleHeight, command});
    REQUIRE(p.steps.size() == 3);
    return p.steps[2];
}

}  // namespace

TEST_CASE("parse: the API's defaults are the documented ones", "[cli][parse]")
{
    const HeightOptions h;
    CHECK(h.normals.convention == NormalConvention::Auto);
    CHECK(h.normals.max_angle == 85.0f);
    CHECK(h.normals.float_encoding == FloatEncoding::Signed);
    CHECK(h.method == HeightMethod::Auto);
    CHECK(h.boundary == Boundary::Auto);
    CHECK(h.impl == RayImpl::Fast);
    CHECK(h.rays == 32);
    CHECK(h.radius == 64.0f);
    CHECK(h.phase == 0.5f);
    CHECK(h.directions == RayDirections::Rational);
    CHECK(h.skip_flat);
    CHECK(h.highpass == 0.0f);
    CHECK(h.mask == nullptr);
    CHECK_FALSE(h.mask_alpha);
    CHECK(h.exec.device == "auto");
    const CorrectOptions c;
    CHECK(c.scale == 0.0f);
    CHECK(c.theta == 5.0f);
    CHECK(c.nodes == CorrectNodes::Corner);
    CHECK(c.boundary == CorrectBoundary::Auto);
    CHECK(c.fix_mask == nullptr);
    CHECK(c.fix_width == 0.0f);
    CHECK(c.iterations == 0);
    CHECK(c.tolerance == 2e-5f);
    CHECK(c.levels == 0);
    CHECK(c.threshold == 1e-3f);
    CHECK(c.skip_tiles);
    CHECK(c.search == CorrectSearch::Brent);
    CHECK(c.relax == 1.5f);
    CHECK(c.polish == 2);
    const BakeOptions b;
    CHECK(b.filter == BakeFilter::Bilinear);
    CHECK(b.colorspace == BakeColorspace::Auto);
    CHECK(b.kind == BakeKind::Auto);
    CHECK(b.wrap == BakeWrap::Auto);
}

TEST_CASE("parse: a command without modifiers gets the API's defaults", "[cli][parse]")
{
    const HeightOptions h0;
    const Step h = step_of("--height");
    CHECK(h.operation == "height");
    CHECK(h.height.normals.convention == h0.normals.convention);
    CHECK(h.height.normals.max_angle == h0.normals.max_angle);
    CHECK(h.height.normals.float_encoding == h0.normals.float_encoding);
    CHECK(h.height.method == h0.method);
    CHECK(h.height.boundary == h0.boundary);
    CHECK(h.height.impl == h0.impl);
    CHECK(h.height.rays == h0.rays);
    CHECK(h.height.radius == h0.radius);
    CHECK(h.height.phase == h0.phase);
    CHECK(h.height.directions == h0.directions);
    CHECK(h.height.skip_flat == h0.skip_flat);
    CHECK(h.height.highpass == h0.highpass);
    CHECK_FALSE(h.height.mask_alpha);
    CHECK(h.mask_file.empty());

    const SlopeOptions s0;
    const Step s = step_of("--slopes");
    CHECK(s.operation == "slopes");
    CHECK(s.slopes.normals.convention == s0.normals.convention);
    CHECK(s.slopes.normals.max_angle == s0.normals.max_angle);
    CHECK(s.slopes.normals.float_encoding == s0.normals.float_encoding);

    const CorrectOptions c0;
    const Step c = step_of("--correct");
    CHECK(c.operation == "correct");
    CHECK(c.correct.scale == c0.scale);
    CHECK(c.correct.theta == c0.theta);
    CHECK(c.correct.nodes == c0.nodes);
    CHECK(c.correct.boundary == c0.boundary);
    CHECK(c.correct.iterations == c0.iterations);
    CHECK(c.correct.tolerance == c0.tolerance);
    CHECK(c.correct.levels == c0.levels);
    CHECK(c.correct.threshold == c0.threshold);
    CHECK(c.correct.skip_tiles == c0.skip_tiles);
    CHECK(c.correct.fix_width == c0.fix_width);
    CHECK(c.fix_file.empty());

    const BakeOptions b0;
    const Step b = step_of("--bake");
    CHECK(b.operation == "bake");
    CHECK(b.bake.filter == b0.filter);
    CHECK(b.bake.colorspace == b0.colorspace);
    CHECK(b.bake.kind == b0.kind);
    CHECK(b.bake.wrap == b0.wrap);
}

TEST_CASE("parse: every decoding modifier lands in its field, for --slopes and --height", "[cli][parse]")
{
    for (const char* cmd : {"--slopes", "--height"}) {
        INFO(cmd);
        auto decoding = [&](const std::string& mods) {
            const Step s = step_of(std::string(cmd) + ":" + mods);
            return std::string(cmd) == "--slopes" ? s.slopes.normals : s.height.normals;
        };
        CHECK(decoding("normal=opengl").convention == NormalConvention::OpenGL);
        CHECK(decoding("normal=directx").convention == NormalConvention::DirectX);
        CHECK(decoding("normal=auto").convention == NormalConvention::Auto);
        CHECK(decoding("max_angle=60").max_angle == 60.0f);
        CHECK(decoding("max_angle=89.5").max_angle == 89.5f);
        CHECK(decoding("range=unsigned").float_encoding == FloatEncoding::Unsigned);
        CHECK(decoding("range=signed").float_encoding == FloatEncoding::Signed);
        const NormalDecoding all = decoding("range=unsigned:normal=directx:max_angle=70");
        CHECK(all.convention == NormalConvention::DirectX);
        CHECK(all.max_angle == 70.0f);
        CHECK(all.float_encoding == FloatEncoding::Unsigned);
    }
}

TEST_CASE("parse: every --height modifier lands in its field", "[cli][parse]")
{
    auto h = [](const std::string& mods) { return step_of("--height:" + mods).height; };
    CHECK(h("method=poisson").method == HeightMethod::Poisson);
    CHECK(h("method=rays").method == HeightMethod::Rays);
    CHECK(h("method=auto").method == HeightMethod::Auto);
    // A ray modifier makes auto mean rays.
    for (const char* ray_mod :
         {"rays=8", "radius=9", "phase=0.1", "impl=fast", "skip=on", "directions=rational"}) {
        INFO(ray_mod);
        CHECK(h(ray_mod).method == HeightMethod::Rays);
    }
    CHECK(h("impl=reference").impl == RayImpl::Reference);
    CHECK(h("impl=fast").impl == RayImpl::Fast);
    CHECK(h("impl=reference:directions=exact").directions == RayDirections::Exact);
    CHECK(h("directions=rational").directions == RayDirections::Rational);
    CHECK(h("rays=7").rays == 7);
    CHECK(h("radius=12.5").radius == 12.5f);
    CHECK(h("phase=0.25").phase == 0.25f);
    CHECK(h("phase=0").phase == 0.0f);
    CHECK_FALSE(h("skip=off").skip_flat);
    CHECK(h("skip=on").skip_flat);
    CHECK(h("boundary=periodic").boundary == Boundary::Periodic);
    CHECK(h("boundary=free").boundary == Boundary::Free);
    CHECK(h("boundary=auto").boundary == Boundary::Auto);
    CHECK(h("method=rays:boundary=clip").boundary == Boundary::Free);
    CHECK(h("method=rays:boundary=periodic").boundary == Boundary::Periodic);
    // one per axis, x first
    CHECK(h("boundary=periodic,free").boundary == Boundaries{Boundary::Periodic, Boundary::Free});
    CHECK(h("boundary=free,periodic").boundary == Boundaries{Boundary::Free, Boundary::Periodic});
    CHECK(step_of("--normals:boundary=periodic,free").normals.boundary ==
          Boundaries{Boundary::Periodic, Boundary::Free});
    CHECK(step_of("--preview:boundary=free,periodic").preview.boundary ==
          Boundaries{Boundary::Free, Boundary::Periodic});
    CHECK(h("highpass=16").highpass == 16.0f);
    CHECK(h("highpass=16").method == HeightMethod::Auto);
    CHECK(h("mask=alpha").mask_alpha);
    const Step file_mask = step_of("--height:mask=" + kSampleHeight);
    CHECK(file_mask.mask_file == kSampleHeight);
    CHECK_FALSE(file_mask.height.mask_alpha);
    const HeightOptions many =
        h("rays=5:radius=7:phase=0.75:boundary=clip:impl=reference:directions=exact:skip=off");
    CHECK(many.method == HeightMethod::Rays);
    CHECK(many.rays == 5);
    CHECK(many.radius == 7.0f);
    CHECK(many.phase == 0.75f);
    CHECK(many.boundary == Boundary::Free);
    CHECK(many.impl == RayImpl::Reference);
    CHECK(many.directions == RayDirections::Exact);
    CHECK_FALSE(many.skip_flat);
}

TEST_CASE("parse: every --correct modifier lands in its field", "[cli][parse]")
{
    auto c = [](const std::string& mods) { return step_of("--correct:" + mods).correct; };
    CHECK(c("scale=0.05").scale == 0.05f);
    CHECK(c("theta=2.5").theta == 2.5f);
    CHECK(c("theta=0").theta == 0.0f);
    CHECK(c("nodes=corner").nodes == CorrectNodes::Corner);
    CHECK(c("nodes=center").nodes == CorrectNodes::Center);
    CHECK(c("boundary=periodic").boundary == CorrectBoundary::Periodic);
    CHECK(c("boundary=fixed").boundary == CorrectBoundary::Fixed);
    CHECK(c("boundary=periodic,fixed").boundary ==
          CorrectBoundaries(CorrectBoundary::Periodic, CorrectBoundary::Fixed));
    CHECK(c("boundary=fixed,periodic").boundary ==
          CorrectBoundaries(CorrectBoundary::Fixed, CorrectBoundary::Periodic));
    CHECK(c("boundary=auto").boundary == CorrectBoundary::Auto);
    CHECK(c("iterations=17").iterations == 17);
    CHECK(c("iterations=auto").iterations == 0);
    CHECK(c("tolerance=1e-3").tolerance == 1e-3f);
    CHECK(c("levels=3").levels == 3);
    CHECK(c("levels=auto").levels == 0);
    CHECK(c("threshold=0.01").threshold == 0.01f);
    CHECK(c("threshold=0").threshold == 0.0f);
    CHECK_FALSE(c("skip=off").skip_tiles);
    CHECK(c("skip=on").skip_tiles);
    CHECK(c("search=ternary").search == CorrectSearch::Ternary);
    CHECK(c("search=golden").search == CorrectSearch::Golden);
    CHECK(c("search=brent").search == CorrectSearch::Brent);
    CHECK(c("relax=1").relax == 1.0f);
    CHECK(c("relax=1.75").relax == 1.75f);
    const CorrectOptions tent = c("fix=height:0.25:0.5");
    CHECK(tent.fix_height == 0.25f);
    CHECK(tent.fix_width == 0.5f);
    const CorrectOptions tent2 = c("scale=2:fix=height:-1.5:3:theta=1");
    CHECK(tent2.fix_height == -1.5f);
    CHECK(tent2.fix_width == 3.0f);
    CHECK(tent2.scale == 2.0f);
    CHECK(tent2.theta == 1.0f);
    const Step file_fix = step_of("--correct:fix=" + kSampleHeight);
    CHECK(file_fix.fix_file == kSampleHeight);
    CHECK(file_fix.correct.fix_width == 0.0f);
}

TEST_CASE("parse: every --bake modifier lands in its field", "[cli][parse]")
{
    auto b = [](const std::string& mods) { return step_of("--bake:" + mods).bake; };
    CHECK(b("filter=bicubic").filter == BakeFilter::Bicubic);
    CHECK(b("filter=bilinear").filter == BakeFilter::Bilinear);
    CHECK(b("colorspace=sRGB").colorspace == BakeColorspace::SRGB);
    CHECK(b("colorspace=srgb").colorspace == BakeColorspace::SRGB);
    CHECK(b("colorspace=linear").colorspace == BakeColorspace::Linear);
    CHECK(b("colorspace=raw").colorspace == BakeColorspace::Raw);
    CHECK(b("colorspace=auto").colorspace == BakeColorspace::Auto);
    CHECK(b("kind=color").kind == BakeKind::Color);
    CHECK(b("kind=normal").kind == BakeKind::Normal);
    CHECK(b("kind=data").kind == BakeKind::Data);
    CHECK(b("kind=height").kind == BakeKind::Height);
    CHECK(b("kind=auto").kind == BakeKind::Auto);
    CHECK(b("wrap=periodic").wrap == BakeWrap::Periodic);
    CHECK(b("wrap=clamp").wrap == BakeWrap::Clamp);
    CHECK(b("wrap=auto").wrap == BakeWrap::Auto);
}

TEST_CASE("parse: options apply to the steps that follow, the stack is tracked", "[cli][parse]")
{
    const Program p = parse_command_line(
        {"-v",   "--device", "cpu",           kSampleNormal, "--height", "-o",          "a.exr",
         "-d",   "uint16",   "--compression", "zip",         "-o",       "b.png",       "-d",
         "half", "-o",       "c.exr",         "--report",    "r.json",   kSampleHeight, "--correct:scale=1",
         "-o",   "d.exr"});
    CHECK(p.verbose);
    CHECK(p.device == "cpu");
    CHECK(p.report == "r.json");
    REQUIRE(p.steps.size() == 8);
    CHECK(p.steps[0].kind == Step::Kind::Read);
    CHECK(p.steps[0].path == kSampleNormal);
    const Step& a = p.steps[2];
    CHECK(a.kind == Step::Kind::Write);
    CHECK(a.path == "a.exr");
    CHECK(a.format == OIIO::TypeDesc::FLOAT);
    CHECK_FALSE(a.format_given);
    CHECK(a.compression.empty());
    const Step& b = p.steps[3];
    CHECK(b.path == "b.png");
    CHECK(b.format == OIIO::TypeDesc::UINT16);
    CHECK(b.format_given);
    CHECK(b.compression == "zip");
    const Step& c = p.steps[4];
    CHECK(c.format == OIIO::TypeDesc::HALF);
    CHECK(c.compression == "zip");
    CHECK(p.steps[5].kind == Step::Kind::Read);
    CHECK(p.steps[6].operation == "correct");
    CHECK(p.steps[7].format == OIIO::TypeDesc::HALF);
    CHECK(parse_command_line({kSampleNormal, "-d", "uint8", "-o", "x.png"}).steps[1].format ==
          OIIO::TypeDesc::UINT8);
    CHECK(parse_command_line({kSampleNormal, "-d", "float", "-o", "x.exr"}).steps[1].format ==
          OIIO::TypeDesc::FLOAT);
    // the device is the program's, for every step (stack_runner's Execution)
    CHECK(parse_command_line({kSampleNormal, "--slopes"}).device == "auto");
    CHECK(parse_command_line({"--device", "0:0", kSampleNormal, kSampleNormal, "--bake"}).device == "0:0");
    CHECK(parse_command_line({"--help"}).help);
    CHECK_FALSE(parse_command_line({"--help"}).help_markdown);
    CHECK(parse_command_line({"--help:format=markdown"}).help_markdown);
    CHECK_THROWS_WITH(parse_command_line({"--help:format=html"}),
                      Catch::Contains("--help takes :format=markdown"));
    CHECK(parse_command_line({"--version"}).version);
    CHECK(parse_command_line({"--list-devices"}).list_devices);
    CHECK_FALSE(parse_command_line({kSampleNormal}).verbose);
}

TEST_CASE("parse: nonsense is a usage error naming the argument", "[cli][parse][errors]")
{
    const std::vector<std::pair<std::vector<std::string>, const char*>> bad = {
        {{kSampleNormal, "--height:rays=0"}, "rays=0"},
        {{kSampleNormal, "--height:rays=4097"}, "rays=4097"},
        {{kSampleNormal, "--height:radius=0"}, "radius=0"},
        {{kSampleNormal, "--height:phase=1"}, "phase=1"},
        {{kSampleNormal, "--height:phase=-0.1"}, "phase=-0.1"},
        {{kSampleNormal, "--height:max_angle=90"}, "max_angle=90"},
        {{kSampleNormal, "--height:max_angle=0"}, "max_angle=0"},
        {{kSampleNormal, "--height:range=both"}, "range=both"},
        {{kSampleNormal, "--height:skip=maybe"}, "skip=maybe"},
        {{kSampleNormal, "--height:rays=8:rays=9"}, "given twice"},
        {{kSampleNormal, "--height:rays"}, "not key=value"},
        {{kSampleNormal, "--height:method=rays:boundary=free"}, "boundary=periodic, clip"},
        {{kSampleNormal, "--slopes:rays=8"}, "unknown modifier 'rays'"},
        {{kSampleNormal, "--correct:theta=20.5"}, "theta=20.5"},
        {{kSampleNormal, "--correct:theta=-1"}, "theta=-1"},
        {{kSampleNormal, "--correct:nodes=edge"}, "nodes=edge"},
        {{kSampleNormal, "--correct:boundary=free"}, "boundary=free"},
        {{kSampleNormal, "--correct:iterations=0"}, "iterations=0"},
        {{kSampleNormal, "--correct:levels=31"}, "levels=31"},
        {{kSampleNormal, "--correct:tolerance=1"}, "tolerance=1"},
        {{kSampleNormal, "--correct:threshold=-1"}, "threshold=-1"},
        {{kSampleNormal, "--correct:relax=2"}, "relax=2"},
        {{kSampleNormal, "--correct:relax=0.9"}, "relax=0.9"},
        {{kSampleNormal, "--correct:search=newton"}, "search=newton"},
        {{kSampleNormal, "--correct:fix=height:1:0"}, "tent half-width DH > 0"},
        {{kSampleNormal, "--correct:fix=height:x:1"}, "write fix=height:H0:DH"},
        {{kSampleNormal, "--correct:fix=height:1:inf"}, "write fix=height:H0:DH"},
        {{kSampleNormal, "--correct:fix=nothing.png"}, "no such file"},
        {{kSampleNormal, "--correct:scale=-1"}, "scale=-1"},
        // overflowing numbers are out of range, with the range; NaN is not a number
        {{kSampleNormal, "--height:phase=inf"}, "phase=inf is out of range; it must be in"},
        {{kSampleNormal, "--height:phase=1e999"}, "phase=1e999 is out of range; it must be in"},
        {{kSampleNormal, "--height:phase=-inf"}, "phase=-inf is out of range"},
        {{kSampleNormal, "--height:phase=nan"}, "phase=nan is not a number"},
        // only regular files are read: a device or FIFO would never end
        {{kSampleNormal, "--height:mask=/dev/zero"},
         "mask=/dev/zero: not a regular file (a character device)"},
        {{kSampleNormal, "--correct:fix=/dev/null"},
         "fix=/dev/null: not a regular file (a character device)"},
        {{kSampleNormal, kSampleNormal, "--preview:env=/tmp"}, "env=/tmp: it is a folder"},
        {{"--batch", "/tmp"}, "--batch /tmp: it is a folder"},
        {{"--batch", "/dev/zero"}, "--batch /dev/zero: not a regular file (a character device)"},
        {{kSampleNormal, "--bake"}, "needs 2 image(s)"},
        {{kSampleNormal, kSampleNormal, "--bake", "--bake"}, "needs 2 image(s) on the stack, has 1"},
        {{kSampleNormal, "--height:highpass=8:mask=alpha"}, "highpass cannot be combined with a mask"},
        {{kSampleNormal, "--height:mask=" + kSampleHeight + ":highpass=8"},
         "highpass cannot be combined with a mask"},
        {{kSampleNormal, kSampleNormal, "--bake:filter=nearest"}, "filter=nearest"},
        {{kSampleNormal, kSampleNormal, "--bake:wrap=mirror"}, "wrap=mirror"},
        {{kSampleNormal, "-d", "int16", "-o", "x.exr"}, "int16"},
        {{kSampleNormal, "--compression", "", "-o", "x.exr"}, "needs a name"},
        {{kSampleNormal, "--report", "r.json", "--slopes"},
         "--report needs one --height or --correct, at most one of each; there are 0 --height and 0 "
         "--correct"},
        {{kSampleNormal, "--dup", "--height", "--report", "r.json", "--dup", "--height"},
         "there are 2 --height and 0 --correct"},
        {{"--dup", kSampleNormal}, "--dup needs 1 image(s) on the stack, has 0"},
        {{"-o", "x.exr"}, "needs 1 image(s)"},
        {{kSampleNormal, "--device"}, "needs a value"},
        {{kSampleNormal, "--correct", "--report", "/nonexistent-folder/r.json"}, "its folder must exist"},
        {{kSampleNormal, "--correct", "--report", "."}, "not a writable file path"},
        {{kSampleNormal, "--correct", "--correct", "--report", "r.json"},
         "there are 0 --height and 2 --correct"},
    };
    for (const auto& [args, message] : bad) {
        std::string joined;
        for (const auto& a : args)
            joined += a + " ";
        INFO(joined);
        try {
            parse_command_line(args);
            FAIL("accepted");
        } catch (const UsageError& e) {
            CHECK(std::string(e.what()).find(message) != std::string::npos);
        }
    }
}
