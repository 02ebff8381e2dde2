// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the tests of the checks share: meshes read back from their files,
// heights and their golden models' inputs.
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

namespace relief::test::checks {

namespace fs = std::filesystem;
using relief::test::json_number;
using relief::test::run_cli;

const std::string kNormalMap = std::string(RELIEF_TEST_DATA) + "/gk_metal_tech_01/normal.png";

inline std::vector<double> as_double(const std::vector<float>& v)
{
    return std::vector<double>(v.begin(), v.end());
}

// A triangle mesh as read back from a file: x, y, z and indices.
struct MeshFile {
    std::vector<double> v;         // 3 per vertex
    std::vector<double> uv;        // 2 per vertex
    std::vector<std::uint32_t> f;  // 3 per triangle
};

inline MeshFile read_obj(const fs::path& p)
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

inline MeshFile read_ply(const fs::path& p)
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

inline MeshFile read_gltf(const fs::path& p)
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
inline MeshCheck check_mesh(const MeshFile& m, const std::vector<float>& h, int w, int ht)
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

}  // namespace relief::test::checks
