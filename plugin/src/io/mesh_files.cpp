// SPDX-License-Identifier: Apache-2.0
// relief::write_mesh — OBJ, PLY (binary) and glTF 2.0 (.gltf with its buffer
// embedded, or .glb) through TinyGLTF; every file written to a temporary
// name in its folder, checked, synced and renamed when complete.
#include "relief/mesh.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cfloat>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <ostream>
#include <stdexcept>
#include <streambuf>

#include "device/cancel.h"
#include "error_state.h"
#include "relief/output_files.h"
#include "temporary_file.h"
#include "relief/version.h"

namespace relief {

namespace {

namespace fs = std::filesystem;

std::string extension(const std::string& path)
{
    std::string e = fs::path(path).extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return e;
}

std::string comment(const std::string& digest)
{
    return "relief " + std::string(version()) + (digest.empty() ? "" : " relief:digest=" + digest);
}

void write_obj(const Mesh& m, std::FILE* f, const std::string& digest)
{
    std::fprintf(f, "# %s\n# x, y in texels (y down the rows), z = scale x height\n",
                 comment(digest).c_str());
    const std::size_t n = m.positions.size() / 3;
    for (std::size_t i = 0; i < n; ++i) {
        host::stop_if_cancelled_every(i);
        std::fprintf(f, "v %.9g %.9g %.9g\n", m.positions[3 * i], m.positions[3 * i + 1],
                     m.positions[3 * i + 2]);
    }
    for (std::size_t i = 0; i < n; ++i) {
        host::stop_if_cancelled_every(i);
        std::fprintf(f, "vt %.9g %.9g\n", m.texcoords[2 * i], m.texcoords[2 * i + 1]);
    }
    for (std::size_t i = 0; i < n; ++i) {
        host::stop_if_cancelled_every(i);
        std::fprintf(f, "vn %.9g %.9g %.9g\n", m.normals[3 * i], m.normals[3 * i + 1], m.normals[3 * i + 2]);
    }
    for (std::size_t t = 0; t < m.triangles.size(); t += 3) {
        host::stop_if_cancelled_every(t);
        const unsigned long a = m.triangles[t] + 1ul, b = m.triangles[t + 1] + 1ul,
                            c = m.triangles[t + 2] + 1ul;
        std::fprintf(f, "f %lu/%lu/%lu %lu/%lu/%lu %lu/%lu/%lu\n", a, a, a, b, b, b, c, c, c);
    }
}

void write_ply(const Mesh& m, std::FILE* f, const std::string& digest)
{
    const std::size_t n = m.positions.size() / 3, faces = m.triangles.size() / 3;
    std::fprintf(f,
                 "ply\nformat binary_little_endian 1.0\ncomment %s\n"
                 "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n"
                 "property float nx\nproperty float ny\nproperty float nz\n"
                 "property float s\nproperty float t\n"
                 "element face %zu\nproperty list uchar uint vertex_indices\nend_header\n",
                 comment(digest).c_str(), n, faces);
    static_assert(sizeof(float) == 4 && sizeof(std::uint32_t) == 4, "PLY float and uint are 4 bytes");
    std::vector<unsigned char> rec;
    rec.reserve(n * 32);
    auto put = [&rec](const void* p, std::size_t bytes) {  // x86 and ARM are little-endian
        const auto* c = static_cast<const unsigned char*>(p);
        rec.insert(rec.end(), c, c + bytes);
    };
    for (std::size_t i = 0; i < n; ++i) {
        host::stop_if_cancelled_every(i);
        put(&m.positions[3 * i], 12);
        put(&m.normals[3 * i], 12);
        put(&m.texcoords[2 * i], 8);
    }
    for (std::size_t t = 0; t < faces; ++t) {
        host::stop_if_cancelled_every(t);
        const unsigned char three = 3;
        put(&three, 1);
        put(&m.triangles[3 * t], 12);
    }
    std::fwrite(rec.data(), 1, rec.size(), f);
}

// A cancel asked between parts of this size of a large copy.
constexpr std::size_t kCopyPart = std::size_t(8) << 20;

// One accessor over a tightly packed view of `data`.
template <class T>
int add_accessor(tinygltf::Model& model, const std::vector<T>& data, int components, int component_type,
                 int type, int target, bool bounds)
{
    host::stop_if_cancelled();
    tinygltf::Buffer& buffer = model.buffers[0];
    while (buffer.data.size() % 4)
        buffer.data.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buffer.data.size();
    view.byteLength = data.size() * sizeof(T);
    view.target = target;
    const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
    for (std::size_t done = 0; done < view.byteLength; done += kCopyPart) {
        host::stop_if_cancelled();
        const std::size_t part = std::min(kCopyPart, view.byteLength - done);
        buffer.data.insert(buffer.data.end(), bytes + done, bytes + done + part);
    }
    model.bufferViews.push_back(view);

    tinygltf::Accessor a;
    a.bufferView = int(model.bufferViews.size()) - 1;
    a.componentType = component_type;
    a.count = data.size() / std::size_t(components);
    a.type = type;
    if (bounds) {  // positions must state them
        a.minValues.assign(std::size_t(components), DBL_MAX);
        a.maxValues.assign(std::size_t(components), -DBL_MAX);
        for (std::size_t i = 0; i < data.size(); ++i) {
            host::stop_if_cancelled_every(i, 3 * 65536);
            double& lo = a.minValues[i % std::size_t(components)];
            double& hi = a.maxValues[i % std::size_t(components)];
            lo = std::min(lo, double(data[i]));
            hi = std::max(hi, double(data[i]));
        }
    }
    model.accessors.push_back(a);
    return int(model.accessors.size()) - 1;
}

// TinyGLTF's output straight into write_mesh's temporary file (its own
// file writer does not report a short write; the whole file in an
// ostringstream first had cost 0.6 s and a copy at 1024^2): each write
// checked, `stop` looked at every 8 MB (TinyGLTF runs on a thread of its
// own, see write_gltf). The stream's exceptions pass the failure or the
// cancel on through TinyGLTF.
class FileOut : public std::streambuf {
public:
    FileOut(std::FILE* f, const std::atomic<bool>& stop) : f_(f), stop_(stop) {}

protected:
    std::streamsize xsputn(const char* s, std::streamsize n) override
    {
        for (std::size_t done = 0; done < std::size_t(n);) {
            const std::size_t part = std::min(std::size_t(n) - done, kPoll - written_ % kPoll);
            if (std::fwrite(s + done, 1, part, f_) != part)
                throw std::runtime_error(std::strerror(errno));
            done += part;
            written_ += part;
            if (written_ % kPoll == 0 && stop_.load())
                throw host::Cancelled();
        }
        return n;
    }
    int_type overflow(int_type c) override
    {
        if (traits_type::eq_int_type(c, traits_type::eof()))
            return traits_type::not_eof(c);
        const char ch = traits_type::to_char_type(c);
        xsputn(&ch, 1);
        return c;
    }

private:
    static constexpr std::size_t kPoll = std::size_t(8) << 20;
    std::FILE* f_;
    const std::atomic<bool>& stop_;
    std::size_t written_ = 0;
};

// The glTF file (buffers embedded) into `f`.
void write_gltf(const Mesh& m, std::FILE* f, bool binary, const std::string& digest)
{
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "relief " + std::string(version());
    if (!digest.empty()) {
        tinygltf::Value::Object extras;
        extras["relief:digest"] = tinygltf::Value(digest);
        model.asset.extras = tinygltf::Value(extras);
    }
    model.buffers.resize(1);
    // (one allocation for the four views, each padded to 4 bytes)
    model.buffers[0].data.reserve(sizeof(float) *
                                      (m.positions.size() + m.normals.size() + m.texcoords.size()) +
                                  sizeof(std::uint32_t) * m.triangles.size() + 16);
    host::stop_if_cancelled();
    // glTF's texture origin is the image's top-left: v = y / H.
    std::vector<float> uv = m.texcoords;
    for (std::size_t i = 1; i < uv.size(); i += 2)
        uv[i] = 1.0f - uv[i];
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    host::stop_if_cancelled();
    prim.attributes["POSITION"] = add_accessor(model, m.positions, 3, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                               TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER, true);
    prim.attributes["NORMAL"] = add_accessor(model, m.normals, 3, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                             TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER, false);
    prim.attributes["TEXCOORD_0"] = add_accessor(model, uv, 2, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                                 TINYGLTF_TYPE_VEC2, TINYGLTF_TARGET_ARRAY_BUFFER, false);
    host::stop_if_cancelled();
    prim.indices = add_accessor(model, m.triangles, 1, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                TINYGLTF_TYPE_SCALAR, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER, false);
    tinygltf::Mesh mesh;
    mesh.name = "relief displaced surface";
    mesh.primitives.push_back(prim);
    model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.mesh = 0;
    model.nodes.push_back(node);
    tinygltf::Scene scene;
    scene.nodes.push_back(0);
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    // TinyGLTF serialises the model and copies its buffer before it writes
    // a byte (0.3 s at 1024^2, with no way in): on a thread of its own, this
    // one asking the cancel meanwhile.
    host::run_asking([&](const std::atomic<bool>& stop) {
        tinygltf::TinyGLTF writer;
        FileOut out(f, stop);
        std::ostream stream(&out);
        stream.exceptions(std::ios::badbit);  // (what FileOut throws comes through)
        if (!writer.WriteGltfSceneToStream(&model, stream, !binary, binary))
            throw std::runtime_error("the glTF writer failed");
    });
}

}  // namespace

std::string mesh_path_problem(const std::string& path)
{
    const fs::path target(path);
    const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    std::error_code ec;
    if (path.empty())
        return "a mesh needs a file name (out=FILE.obj|.ply|.gltf|.glb)";
    if (const std::string why = output_name_problem(path); !why.empty())
        return "cannot write " + why;
    if (!fs::is_directory(folder, ec))
        return "cannot write '" + path + "': the folder '" + folder.string() + "' does not exist";
    if (fs::is_directory(target, ec))
        return "cannot write '" + path + "': it is a folder";
    const std::string e = extension(path);
    if (e != ".obj" && e != ".ply" && e != ".gltf" && e != ".glb")
        return "cannot write '" + path + "': unknown mesh format '" + e + "' (use .obj, .ply, .gltf or .glb)";
    return "";
}

bool write_mesh(const Mesh& m, const std::string& path, const std::string& digest)
{
    const std::string problem = mesh_path_problem(path);
    if (!problem.empty()) {
        detail::set_error(problem);
        return false;
    }
    const std::string e = extension(path);
    try {
        detail::TemporaryFile tmp{fs::path(path)};
        std::FILE* f = tmp.stream();
        std::setvbuf(f, nullptr, _IOFBF, 1 << 20);
        if (e == ".obj")
            write_obj(m, f, digest);
        else if (e == ".ply")
            write_ply(m, f, digest);
        else {
            write_gltf(m, f, e == ".glb", digest);
        }
        // Every write, the flush and the sync checked: a full disk fails here.
        // (The sync of a large mesh takes a while: the cancel is asked
        // meanwhile, and a cancel leaves no file.)
        host::stop_if_cancelled();
        // (errno goes with it: close() reports an earlier failed write's)
        host::run_asking([&tmp, err = errno](const std::atomic<bool>&) {
            errno = err;
            tmp.close();
        });
        tmp.commit();
        return true;
    } catch (const host::Cancelled&) {
        throw;  // (the temporary file is gone; the operation says it was cancelled)
    } catch (const std::exception& x) {
        detail::set_error("cannot write '" + path + "': " + x.what());
        return false;
    }
}

}  // namespace relief
