// SPDX-License-Identifier: Apache-2.0
// --mesh: the triangulated height within its error bound, stitched, with
// unit normals and texture coordinates; its files and their digests.
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
#include "check/check_test.h"

using namespace relief;
using namespace relief::test::checks;

TEST_CASE("mesh: within E at every texel centre, no cracks, fewer triangles, on a real map",
          "[check][mesh][cli][slow]")
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

TEST_CASE("mesh and tessellation outputs: --update skips an unchanged mesh, integer files hold the level",
          "[check][mesh][cli][slow]")
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
