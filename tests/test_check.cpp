// SPDX-License-Identifier: Apache-2.0
// Checking a result: --normals (height -> normal map), the round trip of
// --height, tessellation levels, the displaced mesh and the preview sheet,
// against the golden model of tests/reference/check_reference and
// independent computations.
#include <catch2/catch.hpp>

#include <OpenImageIO/imagebuf.h>
#include <tiny_gltf.h>

#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <random>

#include "check/check_stage.h"
#include "device/compute_context.h"
#include "reference/check_reference.h"
#include "reference/ddm_reference.h"
#include "relief/check.h"
#include "relief/errors.h"
#include "relief/height.h"
#include "relief/imageio.h"
#include "relief/mesh.h"
#include "relief/preview.h"
#include "relief/relief_c.h"
#include "relief/slopes.h"
#include "support/fields.h"
#include "support/images.h"
#include "support/run_cli.h"

using namespace relief;
namespace fs = std::filesystem;
using relief::test::json_number;
using relief::test::run_cli;

namespace {

const std::string kNormalMap = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";

std::vector<double> as_double(const std::vector<float>& v)
{
    return std::vector<double>(v.begin(), v.end());
}

// A triangle mesh as read back from a file: x, y, z and indices.
struct MeshFile {
    std::vector<double> v;         // 3 per vertex
    std::vector<double> uv;        // 2 per vertex
    std::vector<std::uint32_t> f;  // 3 per triangle
};

MeshFile read_obj(const fs::path& p)
{
    MeshFile m;
    std::ifstream in(p);
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ss(line);
        std::string tag;
        ss >> tag;
        if (tag == "v") {
            double x, y, z;
            ss >> x >> y >> z;
            m.v.insert(m.v.end(), {x, y, z});
        } else if (tag == "vt") {
            double a, b;
            ss >> a >> b;
            m.uv.insert(m.uv.end(), {a, b});
        } else if (tag == "f") {
            std::string t;
            while (ss >> t)
                m.f.push_back(std::uint32_t(std::stoul(t.substr(0, t.find('/'))) - 1));
        }
    }
    return m;
}

MeshFile read_ply(const fs::path& p)
{
    MeshFile m;
    std::ifstream in(p, std::ios::binary);
    std::string line;
    std::size_t nv = 0, nf = 0;
    while (std::getline(in, line) && line != "end_header") {
        if (line.rfind("element vertex ", 0) == 0)
            nv = std::stoul(line.substr(15));
        if (line.rfind("element face ", 0) == 0)
            nf = std::stoul(line.substr(13));
    }
    for (std::size_t i = 0; i < nv; ++i) {
        float rec[8];
        in.read(reinterpret_cast<char*>(rec), sizeof rec);
        m.v.insert(m.v.end(), {rec[0], rec[1], rec[2]});
        m.uv.insert(m.uv.end(), {rec[6], rec[7]});
    }
    for (std::size_t t = 0; t < nf; ++t) {
        unsigned char n = 0;
        std::uint32_t idx[3];
        in.read(reinterpret_cast<char*>(&n), 1);
        in.read(reinterpret_cast<char*>(idx), sizeof idx);
        REQUIRE(n == 3);
        m.f.insert(m.f.end(), idx, idx + 3);
    }
    REQUIRE(in.good());
    return m;
}

MeshFile read_gltf(const fs::path& p)
{
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    const bool ok = p.extension() == ".glb" ? loader.LoadBinaryFromFile(&model, &err, &warn, p.string())
                                            : loader.LoadASCIIFromFile(&model, &err, &warn, p.string());
    INFO(err << warn);
    REQUIRE(ok);
    const tinygltf::Primitive& prim = model.meshes.at(0).primitives.at(0);
    auto values = [&](int accessor, auto type_tag) {
        using T = decltype(type_tag);
        const tinygltf::Accessor& a = model.accessors.at(std::size_t(accessor));
        const tinygltf::BufferView& view = model.bufferViews.at(std::size_t(a.bufferView));
        const auto* data =
            reinterpret_cast<const T*>(model.buffers.at(0).data.data() + view.byteOffset + a.byteOffset);
        return std::vector<T>(data, data + view.byteLength / sizeof(T));
    };
    MeshFile m;
    for (float x : values(prim.attributes.at("POSITION"), float()))
        m.v.push_back(x);
    for (float x : values(prim.attributes.at("TEXCOORD_0"), float()))
        m.uv.push_back(x);
    m.f = values(prim.indices, std::uint32_t());
    return m;
}

struct MeshCheck {
    double max_error = 0.0;  // |surface - height| over the texel centres
    std::size_t uncovered = 0, bad_edges = 0, open_edges = 0, flipped = 0;
};

// Independently of relief's own measure: every texel centre's deviation
// (by barycentric interpolation over each triangle covering it), edges used
// by more than two triangles or open away from the border, and triangles
// wound clockwise from +z.
MeshCheck check_mesh(const MeshFile& m, const std::vector<float>& h, int w, int ht)
{
    MeshCheck c;
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
    std::vector<double> err(h.size(), -1.0);
    for (std::size_t t = 0; t < m.f.size(); t += 3) {
        double x[3], y[3], z[3];
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = m.f[t + k], b = m.f[t + (k + 1) % 3];
            ++edges[{std::min(a, b), std::max(a, b)}];
            x[k] = m.v[3 * a];
            y[k] = m.v[3 * a + 1];
            z[k] = m.v[3 * a + 2];
        }
        const double d = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
        if (d <= 0) {
            ++c.flipped;
            continue;
        }
        for (int j = std::max(0, int(std::ceil(std::min({y[0], y[1], y[2]}) - 0.5)));
             j <= std::min(ht - 1, int(std::floor(std::max({y[0], y[1], y[2]}) - 0.5))); ++j)
            for (int i = std::max(0, int(std::ceil(std::min({x[0], x[1], x[2]}) - 0.5)));
                 i <= std::min(w - 1, int(std::floor(std::max({x[0], x[1], x[2]}) - 0.5))); ++i) {
                const double px = i + 0.5, py = j + 0.5;
                const double l0 = ((x[1] - px) * (y[2] - py) - (y[1] - py) * (x[2] - px)) / d;
                const double l1 = ((x[2] - px) * (y[0] - py) - (y[2] - py) * (x[0] - px)) / d;
                const double l2 = 1.0 - l0 - l1;
                if (l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9)
                    continue;
                const double e = std::abs(l0 * z[0] + l1 * z[1] + l2 * z[2] - h[std::size_t(j) * w + i]);
                err[std::size_t(j) * w + i] = std::max(err[std::size_t(j) * w + i], e);
            }
    }
    for (double e : err) {
        c.uncovered += e < 0;
        c.max_error = std::max(c.max_error, e);
    }
    for (const auto& [e, n] : edges) {
        const double x1 = m.v[3 * e.first], y1 = m.v[3 * e.first + 1];
        const double x2 = m.v[3 * e.second], y2 = m.v[3 * e.second + 1];
        const bool border = (x1 == x2 && (x1 == 0 || x1 == w)) || (y1 == y2 && (y1 == 0 || y1 == ht));
        c.open_edges += n == 1;
        c.bad_edges += n > 2 || (n == 1 && !border);
    }
    return c;
}

}  // namespace

TEST_CASE("normals: the device equals the golden model", "[check]")
{
    // Odd sizes, 1- and 2-texel lines: the edges and wraps of every case.
    // Each axis periodic or free.
    const auto boundary = [](bool periodic) { return periodic ? Boundary::Periodic : Boundary::Free; };
    for (auto [w, ht] : {std::pair{37, 23}, std::pair{1, 9}, std::pair{2, 5}, std::pair{64, 64}})
        for (auto [px, py] :
             {std::pair{true, true}, std::pair{false, false}, std::pair{true, false}, std::pair{false, true}})
            for (bool directx : {false, true}) {
                const std::vector<float> h =
                    test::random_field(std::size_t(w) * ht, unsigned(w * 7 + ht), -3.0f, 3.0f);
                NormalsOptions o;
                o.boundary = {boundary(px), boundary(py)};
                o.convention = directx ? NormalConvention::DirectX : NormalConvention::OpenGL;
                o.scale = 0.7f;
                OIIO::ImageBuf out = relief::normals(test::image(w, ht, 1, h), o);
                REQUIRE(out.initialized());
                REQUIRE(out.nchannels() == 3);
                const auto want = reference::height_normals(as_double(h), w, ht, px, py, 0.7, directx);
                INFO(w << "x" << ht << " periodic x " << px << ", y " << py << ", directx " << directx);
                CHECK(test::max_abs_diff(test::pixels(out), want) < 1e-5);
            }
}

TEST_CASE("normals: a tilted plane gives its own normal, one-sided at free edges", "[check]")
{
    // h = 0.5 x - 2 y: every difference, central or one-sided, is exact.
    const int w = 9, ht = 7;
    std::vector<float> h(w * ht);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x)
            h[y * w + x] = 0.5f * x - 2.0f * y;
    NormalsOptions o;
    o.boundary = Boundary::Free;
    const std::vector<float> n = test::pixels(relief::normals(test::image(w, ht, 1, h), o));
    const double len = std::sqrt(0.25 + 4.0 + 1.0);
    for (std::size_t t = 0; t < h.size(); ++t) {
        CHECK(n[3 * t] == Approx(-0.5 / len).margin(1e-6));
        CHECK(n[3 * t + 1] == Approx(-(2.0 / len)).margin(1e-6));  // OpenGL: G = -n_y, n_y = 2/len
        CHECK(n[3 * t + 2] == Approx(1.0 / len).margin(1e-6));
    }
}

TEST_CASE("normals: auto takes the boundary the height was integrated with, else each axis's seam test",
          "[check]")
{
    // A ramp jumps across the seam: the seam test alone says free.
    const int w = 16, ht = 16;
    std::vector<float> h(w * ht);
    for (int i = 0; i < w * ht; ++i)
        h[i] = float(i % w);
    OIIO::ImageBuf img = test::image(w, ht, 1, h);
    NormalsOptions free_o, periodic_o, auto_o;
    free_o.boundary = Boundary::Free;
    periodic_o.boundary = Boundary::Periodic;
    const auto f = test::pixels(relief::normals(img, free_o));
    const auto p = test::pixels(relief::normals(img, periodic_o));
    CHECK(test::max_abs_diff(test::pixels(relief::normals(img, auto_o)), f) == 0.0);
    img.specmod().attribute("relief:parameters", "method=poisson boundary=periodic highpass=0");
    CHECK(test::max_abs_diff(test::pixels(relief::normals(img, auto_o)), p) == 0.0);
    CHECK(test::max_abs_diff(f, p) > 0.1);

    // Without a record each axis takes its own seam test: a ramp along x
    // with a whole wave along y tiles along y only.
    for (int i = 0; i < w * ht; ++i)
        h[i] = float(i % w) + 3.0f * float(std::sin(2.0 * M_PI * (i / w) / ht));
    const OIIO::ImageBuf wave = test::image(w, ht, 1, h);
    NormalsOptions fp;
    fp.boundary = {Boundary::Free, Boundary::Periodic};
    const auto want = test::pixels(relief::normals(wave, fp));
    CHECK(test::max_abs_diff(test::pixels(relief::normals(wave, auto_o)), want) == 0.0);
    CHECK(test::max_abs_diff(test::pixels(relief::normals(wave, free_o)), want) > 0.01);
}

TEST_CASE("normals: auto on a height one texel wide or tall is free (a seam needs two texels)", "[check]")
{
    // Period 3 along the long axis: its seam alone would pass as periodic.
    for (const auto& [w, ht] : {std::pair<int, int>{12, 1}, {1, 12}}) {
        INFO(w << "x" << ht);
        std::vector<float> h(std::size_t(w) * ht);
        for (std::size_t i = 0; i < h.size(); ++i)
            h[i] = 0.25f * float(i % 3);
        const OIIO::ImageBuf img = test::image(w, ht, 1, h);
        NormalsOptions free_o, periodic_o, auto_o;
        free_o.boundary = Boundary::Free;
        periodic_o.boundary = Boundary::Periodic;
        const auto f = test::pixels(relief::normals(img, free_o));
        CHECK(test::max_abs_diff(test::pixels(relief::normals(img, auto_o)), f) == 0.0);
        CHECK(test::max_abs_diff(test::pixels(relief::normals(img, periodic_o)), f) > 0.01);
    }
}

TEST_CASE("normals: refuses NaN heights and directx/opengl only", "[check]")
{
    std::vector<float> h(16, 0.0f);
    h[5] = NAN;
    OIIO::ImageBuf out;
    CHECK_FALSE(relief::normals(out, test::image(4, 4, 1, h)));
    CHECK_THAT(geterror(), Catch::Contains("NaN or infinite value at texel (1, 1)"));
    NormalsOptions o;
    o.convention = NormalConvention::Auto;
    CHECK_FALSE(relief::normals(out, test::image(4, 4, 1, std::vector<float>(16, 0.0f)), o));
}

TEST_CASE("normals: the command line writes (v + 1)/2 in integer files and the decoded height round-trips",
          "[check][cli]")
{
    const fs::path d = test::scratch("check_normals_cli");
    const auto r = run_cli("'" + kNormalMap + "' --height:normal=opengl -o '" + (d / "h.exr").string() +
                           "' --normals:normal=directx -o '" + (d / "n.exr").string() + "' -d uint16 -o '" +
                           (d / "n.png").string() + "'");
    REQUIRE(r.rc == 0);
    const auto f = test::file_pixels(d / "n.exr"), u = test::file_pixels(d / "n.png");
    REQUIRE(f.size() == u.size());
    std::vector<float> decoded(u.size());
    for (std::size_t i = 0; i < u.size(); ++i)
        decoded[i] = 2.0f * u[i] - 1.0f;
    CHECK(test::max_abs_diff(f, decoded) < 2.0 / 65535.0);
    // The float file against the golden model of the height just written.
    const auto h = test::file_pixels(d / "h.exr");
    const auto want = reference::height_normals(as_double(h), 512, 512, true, 1.0, true);
    CHECK(test::max_abs_diff(f, want) < 1e-5);
}

TEST_CASE("tessellation: the device's levels are the golden model's", "[check]")
{
    for (auto [w, ht, patch] : {std::tuple{70, 45, 16}, std::tuple{64, 64, 32}, std::tuple{33, 17, 8}}) {
        const std::vector<float> hf = test::waves(w, ht, 6.0, unsigned(w));
        const auto err = reference::tessellation_errors(as_double(hf), w, ht, patch, 2.0);
        for (float e : {0.05f, 0.5f}) {
            TessellationOptions o;
            o.patch = patch;
            o.error = e;
            o.scale = 2.0f;
            OIIO::ImageBuf lv = relief::tessellation(test::image(w, ht, 1, hf), o);
            REQUIRE(lv.spec().width == (w + patch - 1) / patch);
            REQUIRE(lv.spec().height == (ht + patch - 1) / patch);
            const auto got = test::pixels(lv);
            for (std::size_t p = 0; p < got.size(); ++p) {
                int want = 64;
                for (int L = 64; L >= 1; --L)
                    if (err[p * 64 + L - 1] <= e)
                        want = L;
                // float against double: only a level whose error is within
                // 1e-4 of E may come out the other way.
                bool borderline = false;
                for (int L = 1; L <= 64; ++L)
                    borderline |= std::abs(err[p * 64 + L - 1] - e) < 1e-4;
                INFO(w << "x" << ht << " patch " << patch << " E " << e << " p " << p);
                if (!borderline)
                    CHECK(got[p] == want);
            }
        }
    }
}

TEST_CASE("tessellation: flat patches get level 1, detail more", "[check]")
{
    // A 512^2 map whose left half is flat.
    const int w = 512, ht = 512;
    std::vector<float> h = test::waves(w, ht, 20.0, 3);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w / 2; ++x)
            h[std::size_t(y) * w + x] = 1.5f;
    TessellationOptions o;
    o.patch = 32;
    o.error = 0.1f;
    CHECK(
        relief::tessellation(test::image(w, ht, 1, h), o).spec().get_string_attribute("relief:parameters") ==
        "patch=32 error=0.1 scale=1");  // as the modifiers are written, not error=0.100000001
    o.error = 0.5f;
    const auto lv = test::pixels(relief::tessellation(test::image(w, ht, 1, h), o));
    REQUIRE(lv.size() == 16 * 16);
    int raised = 0;
    for (int py = 0; py < 16; ++py)
        for (int px = 0; px < 16; ++px) {
            INFO(px << ", " << py);
            if (px < 8)
                CHECK(lv[py * 16 + px] == 1.0f);
            else
                raised += lv[py * 16 + px] > 1.0f;
        }
    // Waves of amplitude 20 bend more than 0.5 texel over most 32-texel patches.
    CHECK(raised > 100);
}

TEST_CASE("round trip: HeightReport equals the golden model under the boundary the height used", "[check]")
{
    // A small tiling map: its border texels (a quarter of them) tell
    // wrapped differences from one-sided ones.
    const int w = 24, ht = 20;
    NormalsOptions no;
    no.boundary = Boundary::Periodic;
    const OIIO::ImageBuf normals = relief::normals(test::image(w, ht, 1, test::waves(w, ht, 3.0, 9)), no);
    SlopeOptions so;
    so.normals.convention = NormalConvention::OpenGL;
    const auto g = as_double(test::pixels(relief::slopes(normals, so)));
    const auto boundary = [](bool periodic) { return periodic ? Boundary::Periodic : Boundary::Free; };
    const auto word = [](bool periodic) { return std::string(periodic ? "periodic" : "free"); };
    for (auto [px, py] :
         {std::pair{true, true}, std::pair{false, false}, std::pair{true, false}, std::pair{false, true}}) {
        HeightOptions o;
        o.normals.convention = NormalConvention::OpenGL;
        o.boundary = {boundary(px), boundary(py)};
        HeightReport r;
        o.report = &r;
        const auto h = as_double(test::pixels(relief::height(normals, o)));
        const auto want = reference::round_trip(g, h, w, ht, px, py);
        // (each axis's differences count: the other boundary along either)
        const auto other = reference::round_trip(g, h, w, ht, px == py ? !px : py, px == py ? !py : px);
        INFO("periodic x " << px << ", y " << py);
        CHECK(r.boundary == (px == py ? word(px) : word(px) + "," + word(py)));
        CHECK(r.angular_error_mean == Approx(want.mean).epsilon(1e-4).margin(1e-6));
        CHECK(r.angular_error_p95 == Approx(want.p95).epsilon(1e-4).margin(1e-6));
        CHECK(r.angular_error_max == Approx(want.max).epsilon(1e-4).margin(1e-6));
        CHECK(r.residual_share == Approx(want.residual_share).epsilon(1e-4).margin(1e-9));
        CHECK(std::abs(other.mean - want.mean) > 1e-3 * want.mean + 1e-3);
    }
}

TEST_CASE("round trip: --report's height object matches an independent computation", "[check][cli]")
{
    const fs::path d = test::scratch("check_round_trip");
    // The golden DDM of the input (8-bit OpenGL/DirectX codes, the default 85 degree clamp).
    const std::vector<float> codes = test::file_pixels(kNormalMap);
    for (const char* method : {"poisson:boundary=free", "rays:radius=16:boundary=periodic"}) {
        const bool periodic = std::string(method).find("periodic") != std::string::npos;
        const auto r = run_cli("'" + kNormalMap + "' --height:normal=directx:method=" + method + " -o '" +
                               (d / "h.exr").string() + "' --report '" + (d / "r.json").string() + "' -v");
        INFO(method << ": " << r.err);
        REQUIRE(r.rc == 0);
        const std::string json = test::slurp(d / "r.json");
        REQUIRE(json.find("\"height\": {") != std::string::npos);
        CHECK(json.find("\"correct\"") == std::string::npos);
        CHECK(json.find(std::string("\"method\": \"") + (periodic ? "rays" : "poisson") + "\"") !=
              std::string::npos);
        CHECK(json.find("\"normal_convention\": \"directx\"") != std::string::npos);
        CHECK(json.find(std::string("\"boundary\": \"") + (periodic ? "periodic" : "free") + "\"") !=
              std::string::npos);
        const auto h = test::file_pixels(d / "h.exr");
        const auto g = reference::ddm(codes, 3, 2.0, -1.0, +1.0, 85.0, 1.001 / 255.0).slopes;
        const auto want = reference::round_trip(g, as_double(h), 512, 512, periodic);
        CHECK(json_number(json, "mean") == Approx(want.mean).epsilon(1e-3));
        CHECK(json_number(json, "p95") == Approx(want.p95).epsilon(1e-3));
        CHECK(json_number(json, "max") == Approx(want.max).epsilon(1e-3));
        CHECK(json_number(json, "residual_share") == Approx(want.residual_share).epsilon(1e-3));
        CHECK(want.mean > 0.05);
        // -v prints the same.
        CHECK(r.err.find("round trip: angular error mean") != std::string::npos);
    }
}

TEST_CASE("round trip: --report holds height and correct, written only when the job ends", "[check][cli]")
{
    const fs::path d = test::scratch("check_report_both");
    auto r =
        run_cli("'" + kNormalMap + "' --dup --height -o '" + (d / "h.exr").string() +
                "' --correct --report '" + (d / "r.json").string() + "' -o '" + (d / "o.exr").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    const std::string json = test::slurp(d / "r.json");
    const std::size_t hgt = json.find("\"height\": {"), cor = json.find("\"correct\": {");
    REQUIRE(hgt != std::string::npos);
    REQUIRE(cor != std::string::npos);
    CHECK(hgt < cor);
    CHECK(json_number(json, "energy_after", cor) < json_number(json, "energy_before", cor));
    CHECK(std::isnan(json_number(json, "energy_after", 0)) == false);
    CHECK(json_number(json, "mean", hgt) > 0.0);
    // A job that fails after its --height (a fixation mask of the wrong
    // size) leaves no report.
    fs::remove(d / "r.json");
    REQUIRE(write_image(test::image(4, 4, 1, std::vector<float>(16, 1.0f)), (d / "fix.exr").string()));
    r = run_cli("'" + kNormalMap + "' --height --report '" + (d / "r.json").string() + "' -o '" +
                (d / "h2.exr").string() + "' --correct:fix=" + (d / "fix.exr").string() + " -o '" +
                (d / "o2.exr").string() + "'");
    CHECK(r.rc == 1);
    CHECK_FALSE(fs::exists(d / "r.json"));
}

TEST_CASE("mesh: within E at every texel centre, no cracks, fewer triangles, on a real map",
          "[check][mesh][cli]")
{
    const fs::path d = test::scratch("check_mesh");
    // --mesh leaves the height on the stack for the next command.
    const auto r = run_cli("'" + kNormalMap + "' --height -o '" + (d / "h.exr").string() +
                           "' --mesh:patch=32:error=0.5:out='" + (d / "m.obj").string() +
                           "' --mesh:patch=32:error=0.5:out='" + (d / "m.ply").string() +
                           "' --mesh:patch=32:error=0.5:out='" + (d / "m.glb").string() +
                           "' --mesh:patch=32:error=0.5:out='" + (d / "m.gltf").string() +
                           "' --tessellation:patch=32:error=0.5 -o '" + (d / "levels.exr").string() + "' -v");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    CHECK(r.err.find("patches of 32 texels: level") != std::string::npos);
    OIIO::ImageBuf levels((d / "levels.exr").string());
    REQUIRE(levels.read());
    CHECK(levels.spec().width == 16);
    CHECK(levels.spec().height == 16);
    const auto h = test::file_pixels(d / "h.exr");
    const MeshFile obj = read_obj(d / "m.obj");
    const MeshCheck c = check_mesh(obj, h, 512, 512);
    CHECK(c.max_error <= 0.5);
    CHECK(c.uncovered == 0);
    CHECK(c.bad_edges == 0);
    CHECK(c.flipped == 0);
    CHECK(c.open_edges >= 4);
    CHECK(obj.f.size() / 3 <= 512 * 512);  // at most half of the full grid's 2 x 512^2
    // -v says how many triangles, and what share of the full grid's that is.
    const std::size_t said = r.err.find("mesh: ");
    REQUIRE(said != std::string::npos);
    unsigned long vertices = 0, triangles = 0, full = 0;
    double percent = 0.0;
    REQUIRE(std::sscanf(r.err.c_str() + said,
                        "mesh: %lu vertices, %lu triangles (%lf%% of a full-resolution grid's %lu)",
                        &vertices, &triangles, &percent, &full) == 4);
    CHECK(triangles == obj.f.size() / 3);
    CHECK(vertices == obj.v.size() / 3);
    CHECK(full == 2ul * 512 * 512);
    CHECK(percent == Approx(100.0 * double(triangles) / double(full)).margin(0.05));
    // Texture coordinates (x/W, 1 - y/H).
    for (std::size_t i = 0; i < obj.v.size() / 3; i += 97) {
        CHECK(obj.uv[2 * i] == Approx(obj.v[3 * i] / 512).margin(1e-6));
        CHECK(obj.uv[2 * i + 1] == Approx(1.0 - obj.v[3 * i + 1] / 512).margin(1e-6));
    }
    // The other formats hold the same mesh (glTF's v from the top).
    for (const char* name : {"m.ply", "m.glb", "m.gltf"}) {
        INFO(name);
        const MeshFile other =
            fs::path(name).extension() == ".ply" ? read_ply(d / name) : read_gltf(d / name);
        REQUIRE(other.f == obj.f);
        CHECK(test::max_abs_diff(other.v, obj.v) < 1e-5);
        std::vector<double> uv = other.uv;
        if (std::string(name) != "m.ply")
            for (std::size_t i = 1; i < uv.size(); i += 2)
                uv[i] = 1.0 - uv[i];
        CHECK(test::max_abs_diff(uv, obj.uv) < 1e-6);
    }
}

TEST_CASE("mesh: stitched sides between a flat half and waves, scale and odd sizes", "[check][mesh]")
{
    for (auto [w, ht, patch, scale, error] :
         {std::tuple{200, 130, 32, 1.0f, 0.5f}, std::tuple{97, 61, 16, 3.0f, 0.25f},
          std::tuple{64, 64, 7, 1.0f, 0.1f}}) {
        std::vector<float> h = test::waves(w, ht, 12.0, unsigned(w));
        for (int y = 0; y < ht; ++y)
            for (int x = 0; x < w / 2; ++x)
                h[std::size_t(y) * w + x] = 0.25f;
        TessellationOptions o;
        o.patch = patch;
        o.scale = scale;
        o.error = error;
        Mesh m;
        REQUIRE(displaced_mesh(m, test::image(w, ht, 1, h), o));
        MeshFile f;
        f.v.assign(m.positions.begin(), m.positions.end());
        f.f = m.triangles;
        std::vector<float> sh = h;
        for (float& v : sh)
            v *= scale;
        const MeshCheck c = check_mesh(f, sh, w, ht);
        INFO(w << "x" << ht << " patch " << patch << " scale " << scale << " E " << error);
        CHECK(c.max_error <= error);
        CHECK(c.uncovered == 0);
        CHECK(c.bad_edges == 0);
        CHECK(c.flipped == 0);
        // The mesh's levels start from the level map's and only rise.
        const auto lv = test::pixels(relief::tessellation(test::image(w, ht, 1, h), o));
        REQUIRE(lv.size() == m.levels.size());
        for (std::size_t p = 0; p < lv.size(); ++p)
            CHECK(m.levels[p] >= int(lv[p]));
        CHECK(m.levels[0] == 1);  // flat, away from the waves
    }
}

TEST_CASE("mesh: vertex normals are the surface's unit normals, texture coordinates the vertex's place",
          "[check][mesh]")
{
    // A tilted plane, h = a x + b y texels, scaled by S: away from the
    // borders (where the height clamps) every vertex's normal is
    // (-S a, -S b, 1) / |.| whatever the tessellation.
    const int w = 40, ht = 30;
    const double a = 0.3, b = -0.2, S = 2.0;
    std::vector<float> h(std::size_t(w) * ht);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x)
            h[std::size_t(y) * w + x] = float(a * x + b * y);
    TessellationOptions o;
    o.patch = 8;
    o.scale = float(S);
    Mesh m;
    REQUIRE(displaced_mesh(m, test::image(w, ht, 1, h), o));
    const std::size_t vertices = m.positions.size() / 3;
    REQUIRE(m.normals.size() == 3 * vertices);
    REQUIRE(m.texcoords.size() == 2 * vertices);
    const double len = std::sqrt(S * a * S * a + S * b * S * b + 1.0);
    int interior = 0;
    for (std::size_t i = 0; i < vertices; ++i) {
        const float* p = &m.positions[3 * i];
        const float* n = &m.normals[3 * i];
        INFO("vertex (" << p[0] << ", " << p[1] << ")");
        CHECK(std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]) ==
              Approx(1.0).margin(1e-6));
        CHECK(m.texcoords[2 * i] == Approx(p[0] / w).margin(1e-6));
        CHECK(m.texcoords[2 * i + 1] == Approx(1.0 - p[1] / ht).margin(1e-6));
        if (p[0] >= 1.5 && p[0] <= w - 1.5 && p[1] >= 1.5 && p[1] <= ht - 1.5) {
            ++interior;
            CHECK(n[0] == Approx(-S * a / len).margin(1e-5));
            CHECK(n[1] == Approx(-S * b / len).margin(1e-5));
            CHECK(n[2] == Approx(1.0 / len).margin(1e-5));
        }
    }
    CHECK(interior > 0);
}

TEST_CASE("mesh: bad out= values are refused before anything runs, failures leave no file",
          "[check][mesh][cli][errors]")
{
    const fs::path d = test::scratch("check_mesh_errors");
    for (const std::string& mods :
         {std::string("out=") + (d / "m.stl").string(), std::string("out=/nonexistent-folder/m.obj"),
          std::string("patch=32"), std::string("out=") + d.string() + ".obj:patch=0"}) {
        const auto r =
            run_cli("'" + kNormalMap + "' --height --mesh:" + mods + " -o '" + (d / "h.exr").string() + "'");
        INFO(mods << ": " << r.err);
        CHECK(r.rc == 2);
        CHECK(r.err.find("relief: error: --mesh") != std::string::npos);
    }
    // A NaN height fails the mesh; nothing is written.
    std::vector<float> h(64, 0.0f);
    h[9] = NAN;
    REQUIRE(write_image(test::image(8, 8, 1, h), (d / "nan.exr").string()));
    const auto r = run_cli("'" + (d / "nan.exr").string() + "' --mesh:out='" + (d / "m.obj").string() + "'");
    CHECK(r.rc == 1);
    CHECK(r.err.find("NaN or infinite") != std::string::npos);
    // So does a scale that takes the surface past single precision.
    h[9] = 1e30f;
    REQUIRE(write_image(test::image(8, 8, 1, h), (d / "huge.exr").string()));
    const auto s =
        run_cli("'" + (d / "huge.exr").string() + "' --mesh:scale=1e9:out='" + (d / "m.obj").string() + "'");
    CHECK(s.rc == 1);
    CHECK(s.err.find("overflows single precision") != std::string::npos);
    for (const auto& e : fs::directory_iterator(d))
        CHECK((e.path().filename() == "nan.exr" || e.path().filename() == "huge.exr"));
}

TEST_CASE("mesh files record the digest they are given, in every format", "[check][mesh]")
{
    const fs::path d = test::scratch("check_mesh_digest");
    Mesh m;
    REQUIRE(displaced_mesh(m, test::image(9, 7, 1, test::waves(9, 7, 2.0, 5))));
    const std::string digest = "0123456789abcdef0123456789abcdef";
    for (const char* name : {"m.obj", "m.ply", "m.gltf", "m.glb"}) {
        INFO(name);
        REQUIRE(write_mesh(m, (d / name).string(), digest));
        CHECK(recorded_digest((d / name).string()) == digest);
        REQUIRE(write_mesh(m, (d / name).string()));
        CHECK(recorded_digest((d / name).string()).empty());
    }
}

TEST_CASE("tessellation: patch=1 and patches larger than the map", "[check]")
{
    // One level per texel: a single texel is flat, so level 1 everywhere.
    const std::vector<float> h = test::waves(13, 9, 4.0, 4);
    TessellationOptions o;
    o.patch = 1;
    const OIIO::ImageBuf one = relief::tessellation(test::image(13, 9, 1, h), o);
    REQUIRE(one.spec().width == 13);
    REQUIRE(one.spec().height == 9);
    for (float v : test::pixels(one))
        CHECK(v == 1.0f);
    // One patch over the whole map, as the golden model says.
    o.patch = 64;
    o.error = 0.05f;
    const auto got = test::pixels(relief::tessellation(test::image(13, 9, 1, h), o));
    REQUIRE(got.size() == 1);
    const auto err = reference::tessellation_errors(as_double(h), 13, 9, 64, 1.0);
    int want = 64;
    bool borderline = false;
    for (int L = 64; L >= 1; --L) {
        if (err[std::size_t(L - 1)] <= 0.05)
            want = L;
        borderline |= std::abs(err[std::size_t(L - 1)] - 0.05) < 1e-4;
    }
    if (!borderline)
        CHECK(got[0] == want);
}

TEST_CASE("tessellation: per-patch and per-level launches give the same levels as the golden model",
          "[check]")
{
    auto ctx = host::ComputeContext::acquire("auto");
    for (auto [w, ht, patch, e] : {std::tuple{200, 150, 8, 0.3f}, std::tuple{131, 77, 40, 0.1f}}) {
        const std::vector<float> h = test::waves(w, ht, 15.0, unsigned(ht));
        const auto a = host::tessellation_levels(*ctx, h.data(), w, ht, patch, e, 1.0f,
                                                 host::TessellationLaunch::PerPatch);
        const auto b = host::tessellation_levels(*ctx, h.data(), w, ht, patch, e, 1.0f,
                                                 host::TessellationLaunch::PerLevel);
        INFO(w << "x" << ht << " patch " << patch);
        CHECK(a == b);
        const auto err = reference::tessellation_errors(as_double(h), w, ht, patch, 1.0);
        int compared = 0;
        for (std::size_t p = 0; p < a.size(); ++p) {
            int want = 0;
            bool borderline = false;
            for (int L = 64; L >= 1; --L) {
                if (err[p * 64 + L - 1] <= e)
                    want = L;
                borderline |= std::abs(err[p * 64 + L - 1] - e) < 1e-4;
            }
            if (borderline)
                continue;
            CHECK(int(a[p]) == want);
            ++compared;
        }
        CHECK(compared > int(a.size()) / 2);
        CHECK(*std::max_element(a.begin(), a.end()) > 2);
    }
}

TEST_CASE(
    "normals and levels read back from integer files are plain data: writing them again keeps the codes",
    "[check][io]")
{
    const fs::path d = test::scratch("check_reencode");
    const OIIO::ImageBuf h = test::image(16, 12, 1, test::waves(16, 12, 3.0, 2));
    for (const OIIO::ImageBuf& img :
         {relief::normals(h), relief::tessellation(h, TessellationOptions{4, 0.05f, 1.0f, {}})}) {
        INFO(img.spec().get_string_attribute("relief:method"));
        WriteOptions w;
        w.format = OIIO::TypeDesc::UINT8;
        REQUIRE(write_image(img, (d / "a.png").string(), w));
        OIIO::ImageBuf back;
        REQUIRE(read_image(back, (d / "a.png").string()));
        CHECK(back.spec().get_string_attribute("relief:method").empty());
        REQUIRE(write_image(back, (d / "b.png").string(), w));
        CHECK(test::file_pixels(d / "a.png") == test::file_pixels(d / "b.png"));
    }
}

namespace {

// The mean of channel c over panel (col, row) of a preview sheet whose
// panels are pw x ph (the layout of plugin/src/operations/preview.cpp).
double panel_mean(const OIIO::ImageBuf& sheet, int col, int row, int pw, int ph, int c, int inset = 4)
{
    const int x0 = 16 + col * (pw + 16), y0 = 16 + row * (34 + ph + 52 + 16) + 34;
    double sum = 0.0;
    int n = 0;
    for (int y = y0 + inset; y < y0 + ph - inset; ++y)
        for (int x = x0 + inset; x < x0 + pw - inset; ++x) {
            float v[3];
            sheet.getpixel(x, y, v);
            sum += v[c];
            ++n;
        }
    return sum / n;
}

}  // namespace

TEST_CASE("preview: spherical-harmonic irradiance of analytic environments", "[check][preview]")
{
    // A uniform environment of radiance 1 gives every normal pi.
    OIIO::ImageBuf uniform(OIIO::ImageSpec(64, 32, 3, OIIO::TypeDesc::FLOAT));
    const float one[3] = {1.0f, 1.0f, 1.0f};
    OIIO::ImageBufAlgo::fill(uniform, one);
    const SphericalHarmonics u = environment_harmonics(uniform);
    for (const auto& n : {std::array<float, 3>{0, 0, 1}, std::array<float, 3>{1, 0, 0},
                          std::array<float, 3>{0, -0.6f, 0.8f}}) {
        float e[3];
        irradiance(u, n.data(), e);
        CHECK(e[0] == Approx(M_PI).epsilon(0.01));
    }
    // The upper hemisphere alone (rows above the horizon): an upward normal
    // receives pi, a horizontal one pi/2; a downward one about 0 (order-2
    // harmonics ring slightly).
    OIIO::ImageBuf sky(OIIO::ImageSpec(64, 32, 3, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(sky, one, OIIO::ROI(0, 64, 0, 16));
    const SphericalHarmonics hs = environment_harmonics(sky);
    const float up[3] = {0, 0, 1}, side[3] = {0, 1, 0}, down[3] = {0, 0, -1};
    float e_up[3], e_side[3], e_down[3];
    irradiance(hs, up, e_up);
    irradiance(hs, side, e_side);
    irradiance(hs, down, e_down);
    CHECK(e_up[1] == Approx(M_PI).epsilon(0.05));
    CHECK(e_side[1] == Approx(M_PI / 2).epsilon(0.02));
    CHECK(std::abs(e_down[1]) < 0.1 * M_PI);
    // Light from the image's right (azimuth 0) lights normals tilted to +x.
    OIIO::ImageBuf right(OIIO::ImageSpec(64, 32, 3, OIIO::TypeDesc::FLOAT));
    OIIO::ImageBufAlgo::fill(right, one, OIIO::ROI(0, 8, 8, 16));  // around azimuth 0, above the horizon
    const SphericalHarmonics r = environment_harmonics(right);
    const float px[3] = {0.7f, 0, 0.71f}, nx[3] = {-0.7f, 0, 0.71f}, py[3] = {0, -0.7f, 0.71f};
    float a[3], b[3], c[3];
    irradiance(r, px, a);
    irradiance(r, nx, b);
    irradiance(r, py, c);
    CHECK(a[0] > 2 * b[0]);
    CHECK(c[0] > b[0]);  // azimuth 0..45 leans toward the top (-y) of the image
}

TEST_CASE("preview: the documented command writes an 8-bit sheet at least 1024 wide", "[check][preview][cli]")
{
    const fs::path d = test::scratch("check_preview");
    const auto r =
        run_cli("'" + kNormalMap + "' --dup --height -o '" + (d / "h.exr").string() + "' --report '" +
                (d / "r.json").string() + "' --preview -o '" + (d / "sheet.png").string() + "'");
    INFO(r.err);
    REQUIRE(r.rc == 0);
    auto in = OIIO::ImageInput::open((d / "sheet.png").string());
    REQUIRE(in);
    CHECK(in->spec().width >= 1024);
    CHECK(in->spec().nchannels == 3);
    CHECK(in->spec().format == OIIO::TypeDesc::UINT8);
    CHECK(fs::exists(d / "r.json"));
}

TEST_CASE("preview: any size lays out, from 1x1 to 65536x1, in the CLI, a batch and the C ABI",
          "[check][preview][cli][errors]")
{
    // Panels under about 60 texels tall aborted in OIIO's render_text (the
    // statistics ran off the sheet's bottom), taking a batch's later jobs
    // and a C host with them.
    const fs::path d = test::scratch("check_preview_sizes");
    struct Size {
        int w, h;
    };
    const std::vector<Size> sizes = {{1, 1},      {6, 1},     {100, 16}, {1000, 50},
                                     {4096, 128}, {65536, 1}, {1, 4096}};
    std::ofstream manifest(d / "jobs.txt");
    std::vector<std::vector<float>> maps;
    for (const Size& z : sizes) {
        // Gentle bumps: unit normals of h = 0.3 sin(x / 3) cos(y / 5).
        std::vector<float> n(std::size_t(z.w) * z.h * 3);
        for (int y = 0; y < z.h; ++y)
            for (int x = 0; x < z.w; ++x) {
                const float gx = 0.1f * std::cos(x / 3.0f) * std::cos(y / 5.0f),
                            gy = -0.06f * std::sin(x / 3.0f) * std::sin(y / 5.0f);
                const float inv = 1.0f / std::sqrt(1.0f + gx * gx + gy * gy);
                float* p = &n[3 * (std::size_t(y) * z.w + x)];
                p[0] = -gx * inv;
                p[1] = -gy * inv;
                p[2] = inv;
            }
        maps.push_back(n);
        const std::string name = "n" + std::to_string(z.w) + "x" + std::to_string(z.h);
        REQUIRE(write_image(test::image(z.w, z.h, 3, n), (d / (name + ".exr")).string()));
        manifest << name << ".exr --dup --height --preview -o " << name << ".sheet.png\n";
    }
    manifest.close();
    // One command line each.
    for (const Size& z : sizes) {
        const std::string name = "n" + std::to_string(z.w) + "x" + std::to_string(z.h);
        INFO(name);
        const auto r = run_cli("-v " + name + ".exr --dup --height --preview -o " + name + ".cli.png",
                               "cd '" + d.string() + "' &&");
        INFO(r.err);
        CHECK(r.rc == 0);
        auto in = OIIO::ImageInput::open((d / (name + ".cli.png")).string());
        REQUIRE(in);
        CHECK(in->spec().width >= 3 * 344);
        CHECK(in->spec().height >= 2 * 100);
    }
    // A batch: every job ends, none takes the others with it.
    const auto r = run_cli("--batch jobs.txt", "cd '" + d.string() + "' &&");
    INFO(r.err);
    CHECK(r.rc == 0);
    CHECK(r.err.find(std::to_string(sizes.size()) + " ok, 0 skipped, 0 failed") != std::string::npos);
    // The C ABI: the host survives and gets a sheet.
    for (std::size_t i = 0; i < sizes.size(); ++i) {
        const Size z = sizes[i];
        INFO(z.w << "x" << z.h);
        relief_image normals = {z.w, z.h, 3, RELIEF_FLOAT, maps[i].data(), nullptr}, h{}, sheet{};
        REQUIRE(relief_run("height", "", &normals, 1, &h) == RELIEF_OK);
        const relief_image both[2] = {normals, h};
        CHECK(relief_run("preview", "", both, 2, &sheet) == RELIEF_OK);
        CHECK(sheet.width >= 3 * 344);
        relief_image_free(&h);
        relief_image_free(&sheet);
    }
}

TEST_CASE("preview: a height's own normals light as the height does, and the light comes from where it says",
          "[check][preview]")
{
    // A ramp rising to the right (free edges): its normals lean to -x.
    const int w = 64, ht = 48;
    std::vector<float> h(w * ht);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x)
            h[y * w + x] = 0.6f * x + 2.0f * std::sin(0.3 * y);
    OIIO::ImageBuf height = test::image(w, ht, 1, h);
    NormalsOptions no;
    no.boundary = Boundary::Free;
    const OIIO::ImageBuf normals = relief::normals(height, no);  // OpenGL, float
    PreviewOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    o.boundary = Boundary::Free;
    o.azimuth = 180.0f;  // from the left: the slope faces it
    OIIO::ImageBuf from_left = relief::preview(normals, height, o);
    REQUIRE_FALSE(from_left.has_error());
    // 64 texels are shown 344 wide (nearest texels).
    const int pw = 344, ph = int(std::lround(48 * 344.0 / 64));
    CHECK(from_left.spec().width == 3 * pw + 4 * 16);
    for (int c = 0; c < 3; ++c)
        CHECK(std::abs(panel_mean(from_left, 0, 0, pw, ph, c) - panel_mean(from_left, 1, 0, pw, ph, c)) <
              2.0 / 255);
    o.azimuth = 0.0f;
    OIIO::ImageBuf from_right = relief::preview(normals, height, o);
    // The same ramp turned to rise down the image faces a light from the
    // top of the image (azimuth 90).
    std::vector<float> hy(w * ht);
    for (int y = 0; y < ht; ++y)
        for (int x = 0; x < w; ++x)
            hy[y * w + x] = 0.6f * y + 2.0f * std::sin(0.3 * x);
    const OIIO::ImageBuf height_y = test::image(w, ht, 1, hy);
    const OIIO::ImageBuf normals_y = relief::normals(height_y, no);
    o.azimuth = 90.0f;
    const double from_top = panel_mean(relief::preview(normals_y, height_y, o), 1, 0, pw, ph, 1);
    o.azimuth = 270.0f;
    const double from_bottom = panel_mean(relief::preview(normals_y, height_y, o), 1, 0, pw, ph, 1);
    CHECK(from_top > from_bottom + 0.1);
    // A red environment lights the panels red; the sky, blue.
    const fs::path d = test::scratch("check_preview_env");
    OIIO::ImageBuf red(OIIO::ImageSpec(32, 16, 3, OIIO::TypeDesc::FLOAT));
    const float r[3] = {1.0f, 0.05f, 0.05f};
    OIIO::ImageBufAlgo::fill(red, r);
    REQUIRE(write_image(red, (d / "red.exr").string()));
    o.azimuth = 0.0f;
    o.elevation = 5.0f;  // a grazing key light leaves the colour to the environment
    const OIIO::ImageBuf lit_sky = relief::preview(normals, height, o);
    CHECK(panel_mean(lit_sky, 0, 0, pw, ph, 2) > panel_mean(lit_sky, 0, 0, pw, ph, 0) + 0.05);
    o.env = (d / "red.exr").string();
    const OIIO::ImageBuf lit_red = relief::preview(normals, height, o);
    CHECK(panel_mean(lit_red, 0, 0, pw, ph, 0) > panel_mean(lit_red, 0, 0, pw, ph, 2) + 0.2);
    CHECK(panel_mean(from_left, 1, 0, pw, ph, 1) > panel_mean(from_right, 1, 0, pw, ph, 1) + 0.1);
    // Emboss: the ramp rises toward a light on the right: brighter than mid-grey.
    CHECK(panel_mean(from_right, 2, 0, pw, ph, 0) > 0.6);
    CHECK(panel_mean(from_left, 2, 0, pw, ph, 0) < 0.4);
}

TEST_CASE("preview: the emboss panel is the height one texel toward the light less the height, along x and y",
          "[check][preview]")
{
    // Planes: the height one texel toward the light (bilinear between
    // texels, exact on a plane) less the height is the same everywhere but
    // at the clamped edges, under 1% of the texels here, so the panel is
    // black where it is lower, white where it is higher.
    const int w = 256, ht = 192;
    const int pw = 344, ph = int(std::lround(192 * 344.0 / 256));
    NormalsOptions no;
    no.boundary = Boundary::Free;
    PreviewOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    o.boundary = Boundary::Free;
    const auto emboss = [&](double ax, double ay, float azimuth) {
        std::vector<float> h(w * ht);
        for (int y = 0; y < ht; ++y)
            for (int x = 0; x < w; ++x)
                h[y * w + x] = float(ax * x + ay * y);
        const OIIO::ImageBuf height = test::image(w, ht, 1, h);
        o.azimuth = azimuth;
        const OIIO::ImageBuf sheet = relief::preview(relief::normals(height, no), height, o);
        REQUIRE_FALSE(sheet.has_error());
        return panel_mean(sheet, 2, 0, pw, ph, 0, 12);
    };
    // Rising down the image: the light from the top (azimuth 90) finds the
    // texel above lower, from the bottom higher.
    CHECK(emboss(0.0, 0.6, 90.0f) < 0.05);
    CHECK(emboss(0.0, 0.6, 270.0f) > 0.95);
    // Azimuth 45 looks 0.71 texels right and 0.71 up (between texels):
    // 0.3 x 0.71 higher and 0.6 x 0.71 lower; 315 looks right and down.
    CHECK(emboss(0.3, 0.6, 45.0f) < 0.05);
    CHECK(emboss(0.3, 0.6, 315.0f) > 0.95);
    CHECK(emboss(0.6, 0.3, 45.0f) > 0.95);
    CHECK(emboss(0.6, 0.3, 135.0f) < 0.05);
}

TEST_CASE("preview: the procedural sky lights an upward surface pale blue, every channel lit",
          "[check][preview]")
{
    // A flat map with the key light at the horizon: panel a is the sky's
    // diffuse light alone (zenith blue, a pale horizon, a brown ground).
    const int w = 400, h = 200;
    std::vector<float> up(std::size_t(w) * h * 3, 0.0f);
    for (std::size_t i = 2; i < up.size(); i += 3)
        up[i] = 1.0f;
    PreviewOptions o;
    o.normals.convention = NormalConvention::OpenGL;
    o.elevation = 0.001f;
    const OIIO::ImageBuf sheet = relief::preview(
        test::image(w, h, 3, up), test::image(w, h, 1, std::vector<float>(std::size_t(w) * h, 0.0f)), o);
    REQUIRE_FALSE(sheet.has_error());
    const int W = sheet.spec().width;
    const std::vector<float> px = test::pixels(sheet);
    const int x = (W - 3 * w) / 4 + w / 2;  // the middle of panel a's column
    const auto at = [&](int y) { return &px[3 * (std::size_t(y) * W + x)]; };
    // Down to the first panel: 20 rows of one colour other than the
    // background's (a caption's letters are not that tall).
    const auto same = [&](int a, int b) { return std::equal(at(a), at(a) + 3, at(b)); };
    const auto panel_at = [&](int y) {
        for (int k = 0; k < 20; ++k)
            if (same(y + k, 0) || !same(y + k, y))
                return false;
        return true;
    };
    int y = 0;
    while (y + 20 < sheet.spec().height && !panel_at(y))
        ++y;
    REQUIRE(y + 20 < sheet.spec().height);
    const float* c = at(y + 10);
    INFO("sky light " << c[0] << ", " << c[1] << ", " << c[2]);
    CHECK(c[2] > c[0]);         // blue
    CHECK(c[0] > 0.5f * c[2]);  // pale: red well present
    CHECK(c[1] > c[0]);
}

TEST_CASE("preview: each panel is the map's size at the sheet's scale, in its own cell", "[check][preview]")
{
    // A flat map makes every panel one colour, so each can be found and
    // measured: pw x ph, the same size in every cell, cells in a grid with
    // equal margins, each panel's edges against the background. The panel
    // size follows the rule of the sheet: the map's own resolution, scaled
    // into 344..1024 texels wide (and at most 2048 tall when enlarged).
    struct Case {
        int w, h, pw, ph;
    } cases[] = {{400, 200, 400, 200}, {2048, 1024, 1024, 512}, {100, 300, 344, 1032}, {20, 1000, 41, 2048}};
    // The first case's panels are not resized; the others' are: each keeps
    // its colour.
    std::array<std::array<float, 3>, 5> unscaled{};
    for (const Case& c : cases) {
        INFO(c.w << "x" << c.h);
        std::vector<float> up(std::size_t(c.w) * c.h * 3, 0.0f);
        for (std::size_t i = 2; i < up.size(); i += 3)
            up[i] = 1.0f;
        const OIIO::ImageBuf normals = test::image(c.w, c.h, 3, up);
        const OIIO::ImageBuf flat =
            test::image(c.w, c.h, 1, std::vector<float>(std::size_t(c.w) * c.h, 0.0f));
        PreviewOptions o;
        o.normals.convention = NormalConvention::OpenGL;
        const OIIO::ImageBuf sheet = relief::preview(normals, flat, o);
        REQUIRE_FALSE(sheet.has_error());
        const int W = sheet.spec().width, H = sheet.spec().height;
        const std::vector<float> px = test::pixels(sheet);
        const auto at = [&](int x, int y) {
            const float* p = &px[3 * (std::size_t(y) * W + x)];
            return std::array<float, 3>{p[0], p[1], p[2]};
        };
        const auto background = at(0, 0);
        const int cw = std::max(c.pw, 344);
        REQUIRE((W - 3 * cw) % 4 == 0);
        const int margin = (W - 3 * cw) / 4;
        CHECK(margin > 0);
        // One colour over [x0, x0 + pw) of row y, other than the background.
        const auto panel_row = [&](int x0, int y) {
            const auto first = at(x0, y);
            if (first == background)
                return false;
            for (int x = x0; x < x0 + c.pw; ++x)
                if (at(x, y) != first)
                    return false;
            return true;
        };
        std::array<int, 2> top{};
        for (int row = 0; row < 2; ++row)
            for (int col = 0; col < (row == 0 ? 3 : 2); ++col) {
                INFO("panel " << col << "," << row);
                const int x0 = margin + col * (cw + margin);
                int y0 = row == 0 ? 0 : top[0] + c.ph;
                while (y0 < H && !panel_row(x0, y0))
                    ++y0;
                REQUIRE(y0 + c.ph <= H);
                if (col == 0)
                    top[std::size_t(row)] = y0;
                CHECK(y0 == top[std::size_t(row)]);  // a row's panels line up
                const auto colour = at(x0, y0);
                auto& first = unscaled[std::size_t(row * 3 + col)];
                if (&c == &cases[0])
                    first = colour;
                for (int k = 0; k < 3; ++k)
                    CHECK(std::abs(colour[std::size_t(k)] - first[std::size_t(k)]) <= 1e-5f);
                int uniform_rows = 0;
                for (int y = y0; y < y0 + c.ph; ++y)
                    uniform_rows += panel_row(x0, y) && at(x0, y) == colour;
                CHECK(uniform_rows == c.ph);
                CHECK(at(x0 - 1, y0) == background);  // its left, right and lower edges
                CHECK(at(x0 + c.pw, y0 + c.ph - 1) == background);
                CHECK(at(x0 + c.pw / 2, y0 + c.ph) != colour);
                if (row == 1) {  // d and e: a colour bar under the panel, as wide as the cell
                    int bar = y0 + c.ph;
                    while (bar < H && at(x0, bar) == background)
                        ++bar;
                    REQUIRE(bar < H);
                    int coloured = 0;
                    for (int x = x0; x < x0 + cw; ++x)
                        coloured += at(x, bar + 2) != background;
                    CHECK(coloured == cw);
                    CHECK(at(x0 + cw, bar + 2) == background);
                    CHECK(at(x0, bar + 2) != at(x0 + cw - 1, bar + 2));  // a ramp, not one colour
                }
            }
        // Two rows of cells with equal margins: H = 2 (row pitch) + margin.
        CHECK(H == 2 * (top[1] - top[0]) + margin);
        CHECK(top[1] - top[0] >= std::max(c.ph, 100) + margin);
    }
}

TEST_CASE("preview: refuses mismatched sizes, bad lights and environments", "[check][preview][errors]")
{
    const fs::path d = test::scratch("check_preview_errors");
    const OIIO::ImageBuf height = test::image(8, 8, 1, std::vector<float>(64, 0.0f));
    const OIIO::ImageBuf normals = relief::normals(height);
    OIIO::ImageBuf out;
    CHECK_FALSE(
        relief::preview(out, relief::normals(test::image(8, 6, 1, std::vector<float>(48, 0.0f))), height));
    CHECK_THAT(geterror(), Catch::Contains("the normal map is 8x6, the height 8x8"));
    PreviewOptions o;
    o.elevation = 0.0f;
    CHECK_FALSE(relief::preview(out, normals, height, o));
    CHECK_THAT(geterror(), Catch::Contains("EL in (0, 90]"));
    std::vector<float> bad(64 * 3, 1.0f);
    bad[7] = NAN;
    REQUIRE(write_image(test::image(8, 8, 3, bad), (d / "env.exr").string()));
    o = PreviewOptions();
    o.env = (d / "env.exr").string();
    CHECK_FALSE(relief::preview(out, normals, height, o));
    CHECK_THAT(geterror(), Catch::Contains("NaN"));
    const std::string in = (d / "n.exr").string(), hf = (d / "h.exr").string();
    REQUIRE(write_image(normals, in));
    REQUIRE(write_image(height, hf));
    for (const std::string& mods :
         {std::string("light=90"), std::string("light=90,0"), std::string("light=400,30"),
          std::string("env=") + (d / "missing.exr").string()}) {
        const auto r =
            run_cli("'" + in + "' '" + hf + "' --preview:" + mods + " -o '" + (d / "s.png").string() + "'");
        INFO(mods << ": " << r.err);
        CHECK(r.rc == 2);
        CHECK_FALSE(fs::exists(d / "s.png"));
    }
}

TEST_CASE("mesh and tessellation outputs: --update skips an unchanged mesh, integer files hold the level",
          "[check][mesh][cli]")
{
    const fs::path d = test::scratch("check_mesh_update");
    const std::string h = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/height.png";
    const std::string log = (d / "log.jsonl").string();
    auto run = [&](const std::string& error) {
        fs::remove(log);  // --log appends: each run's line alone
        return run_cli("--update --log '" + log + "' '" + h + "' --mesh:error=" + error + ":out='" +
                       (d / "m.ply").string() + "' --tessellation:error=" + error + " -d uint8 -o '" +
                       (d / "levels.png").string() + "'");
    };
    REQUIRE(run("0.02").rc == 0);
    CHECK(test::slurp(log).find("\"status\":\"ok\"") != std::string::npos);
    REQUIRE(run("0.02").rc == 0);
    CHECK(test::slurp(log).find("\"status\":\"skipped\"") != std::string::npos);
    CHECK(recorded_digest((d / "m.ply").string()).size() == 32);
    // Another error recomputes; the mesh alone gone recomputes too.
    REQUIRE(run("0.03").rc == 0);
    CHECK(test::slurp(log).find("\"status\":\"ok\"") != std::string::npos);
    fs::remove(d / "m.ply");
    REQUIRE(run("0.03").rc == 0);
    CHECK(test::slurp(log).find("\"status\":\"ok\"") != std::string::npos);
    CHECK(fs::exists(d / "m.ply"));
    // The 8-bit level map holds the levels as codes (values k/255).
    const auto codes = test::file_pixels(d / "levels.png");
    OIIO::ImageBuf img;
    REQUIRE(read_image(img, h));
    TessellationOptions o;
    o.error = 0.03f;
    const auto levels = test::pixels(relief::tessellation(img, o));
    REQUIRE(codes.size() == levels.size());
    for (std::size_t i = 0; i < codes.size(); ++i)
        CHECK(std::lround(codes[i] * 255.0f) == std::lround(levels[i]));
    CHECK(*std::max_element(levels.begin(), levels.end()) > 2.0f);
}
