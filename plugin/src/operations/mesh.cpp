// SPDX-License-Identifier: Apache-2.0
// relief::displaced_mesh — the displaced surface tessellated per patch at its
// level, stitched without cracks (docs/design.md §9).
//
// Every vertex lies on a patch's grid or on a patch side, at a rational
// position: x = x0 + (x1 - x0) k / n. Vertices are keyed by that exact
// rational, so the two patches of a shared side meet at the same vertices
// whatever their levels. A shared side carries the union of both patches'
// points; a triangle with an edge on such a side is fanned from its third
// vertex over the side's extra points (the diagonal rule of
// check_level_passes in kernels/check.cl guarantees one side per triangle
// from level 2 on), and a level-1 patch with extra points becomes a fan
// around its centre.
#include "relief/validate.h"
#include "relief/mesh.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "check/check_stage.h"
#include "device/compute_context.h"
#include "device/memory_budget.h"
#include "error_state.h"
#include "results.h"
#include "relief/errors.h"
#include "mesh_builder.h"
#include "seams.h"

namespace relief {

namespace {

using namespace detail::mesh_building;

// What building a mesh holds at its peak, per vertex and per triangle
// (measured: 512^2 at patch=2:error=1e-6, 1.05 M vertices and 2.09 M
// triangles, peaked at 466 MB, about 120 MB of it the process itself):
// the builder's vertex map (about 80 B a node and bucket) and arrays (32 B
// and 12 B a triangle, with their growth), then the finished mesh's copy.
// A glTF file is also assembled in memory (tinygltf's buffer, the bytes,
// base64 for .gltf).
constexpr std::uint64_t kBytesPerVertex = 240, kBytesPerTriangle = 48;
constexpr std::uint64_t kGltfBytesPerVertex = 3 * 32, kGltfBytesPerTriangle = 3 * 12;

// The mesh at the patches' first levels: a patch at level L owns about L^2
// vertices and makes 2 L^2 triangles (sides shared with its neighbours).
// Raised patches add to it; the first levels are what is known before the
// build. Throws when it does not fit in host memory.
void check_mesh_memory(const std::vector<int>& levels, bool gltf)
{
    std::uint64_t vertices = 0, triangles = 0;
    for (int l : levels) {
        vertices += std::uint64_t(std::max(l, 1)) * std::uint64_t(std::max(l, 1));
        triangles += 2 * std::uint64_t(l) * std::uint64_t(l);
    }
    const std::uint64_t need = vertices * (kBytesPerVertex + (gltf ? kGltfBytesPerVertex : 0)) +
                               triangles * (kBytesPerTriangle + (gltf ? kGltfBytesPerTriangle : 0));
    if (const std::string why = host::refuse_host(need); !why.empty())
        throw std::runtime_error("the mesh (about " + std::to_string(vertices) + " vertices, " +
                                 std::to_string(triangles) + " triangles at the patches' first levels) " +
                                 why + "; use a larger error or patch");
}

bool build_mesh(Mesh& mesh, const OIIO::ImageBuf& height, const TessellationOptions& options, bool gltf)
{
    try {
        const detail::OperationScope scope(options.exec);
        detail::require_valid(options);
        const detail::HeightRegion region =
            detail::height_region(height, {}, options.exec, "mesh", options.scale);
        const int w = region.w, ht = region.h;
        const std::vector<float>& h = region.values;
        auto ctx = host::ComputeContext::acquire(options.exec.device);
        const std::vector<std::uint8_t> first =
            host::tessellation_levels(*ctx, h.data(), w, ht, options.patch, options.error, options.scale);
        std::vector<int> levels(first.size());
        for (std::size_t p = 0; p < first.size(); ++p)
            levels[p] = first[p] ? first[p] : host::kMaxTessellationLevel;
        check_mesh_memory(levels, gltf);
        const std::vector<int> start = levels;
        const int px = (w + options.patch - 1) / options.patch, py = (ht + options.patch - 1) / options.patch;

        // The stitched mesh differs from each patch's uniform grid along its
        // sides: measure it, and raise a patch that is off by more than E.
        // The float positions a file holds are what is measured; the margin
        // keeps their rounding from crossing E.
        Builder builder(h, w, ht, options);
        const double limit = double(options.error) * (1.0 - 1e-5);
        std::vector<int> which(levels.size());
        std::iota(which.begin(), which.end(), 0);
        for (;;) {
            builder.build(levels, which);
            // A raised patch changes its own triangles and its neighbours'
            // sides: those are rebuilt and measured again.
            std::vector<char> dirty(levels.size(), 0);
            for (std::size_t p = 0; p < levels.size(); ++p)
                if (builder.errors()[p] > limit && levels[p] < host::kMaxTessellationLevel) {
                    ++levels[p];
                    const int x = int(p) % px, y = int(p) / px;
                    dirty[p] = 1;
                    if (x > 0)
                        dirty[p - 1] = 1;
                    if (x + 1 < px)
                        dirty[p + 1] = 1;
                    if (y > 0)
                        dirty[p - std::size_t(px)] = 1;
                    if (y + 1 < py)
                        dirty[p + std::size_t(px)] = 1;
                }
            which.clear();
            for (std::size_t p = 0; p < levels.size(); ++p)
                if (dirty[p])
                    which.push_back(int(p));
            if (which.empty())
                break;
        }
        mesh = builder.finish();
        host::stop_if_cancelled();
        mesh.raised = 0;
        int over = 0;
        double worst = 0.0;
        for (std::size_t p = 0; p < levels.size(); ++p) {
            mesh.raised += levels[p] > start[p];
            over += mesh.errors[p] > limit;
            worst = std::max(worst, mesh.errors[p]);
        }
        const std::size_t full = 2 * std::size_t(w) * std::size_t(ht);
        detail::say(
            options.exec, Severity::Info,
            "mesh: " + std::to_string(mesh.positions.size() / 3) + " vertices, " +
                std::to_string(mesh.triangles.size() / 3) + " triangles (" +
                detail::format_double("%.1f%%", 100.0 * double(mesh.triangles.size() / 3) / double(full)) +
                " of a full-resolution grid's " + std::to_string(full) + "), largest error " +
                detail::format_double("%.4g", worst) + "; " + std::to_string(mesh.raised) +
                " patch(es) raised above their level to keep the stitched sides within E");
        if (over > 0)
            detail::say(options.exec, Severity::Warning,
                        "mesh: " + std::to_string(over) + " patch(es) exceed error=" +
                            detail::format_double("%g", options.error) + " even at level 64 (largest " +
                            detail::format_double("%.4g", worst) + "); use a smaller patch");
        return true;
    } catch (const std::exception& e) {
        detail::set_error(std::string("mesh: ") + e.what());
        return false;
    }
}

}  // namespace

bool displaced_mesh(Mesh& mesh, const OIIO::ImageBuf& height, const TessellationOptions& options)
{
    return build_mesh(mesh, height, options, false);
}

bool mesh(OIIO::ImageBuf& dst, const OIIO::ImageBuf& height, const MeshOptions& options)
{
    return detail::guarded(dst, "mesh", options.tessellation.exec, options, [&] {
        Mesh m;
        const std::string ext = std::filesystem::path(options.out).extension().string();
        const bool gltf = ext == ".gltf" || ext == ".glb" || ext == ".GLTF" || ext == ".GLB";
        if (!build_mesh(m, height, options.tessellation, gltf) ||
            !write_mesh(m, options.out, options.digest)) {
            dst.errorfmt("{}", relief::geterror(false));
            return false;
        }
        detail::say(options.tessellation.exec, Severity::Info, "mesh: wrote " + options.out);
        if (!dst.copy(height))
            throw std::runtime_error(dst.geterror());
        return true;
    });
}

}  // namespace relief
