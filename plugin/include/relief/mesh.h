// SPDX-License-Identifier: Apache-2.0
#pragma once
// The displaced surface as a triangle mesh: tessellated per patch at its
// level (check.h's tessellation()), stitched so that patches of different
// levels share every edge vertex (no cracks, no T-junctions), and written as
// OBJ, PLY or glTF 2.0 (.gltf, or binary .glb).
#include <OpenImageIO/imagebuf.h>

#include <cstdint>
#include <string>
#include <vector>

#include "mesh_types.h"
#include "relief/check.h"
#include "relief/export.h"

namespace relief {

// Builds the mesh of `height` (channel 0, texels). Each patch starts at its
// tessellation() level; the stitched mesh is then measured at every texel
// centre, and a patch still off by more than E is raised until it is within
// E (or at 64, reported). Returns false and sets geterror() on failure.
RELIEF_API bool displaced_mesh(Mesh& mesh, const OIIO::ImageBuf& height,
                               const TessellationOptions& options = {});

// Writes `mesh` atomically; the format by the extension of `path`.
RELIEF_API bool write_mesh(const Mesh& mesh, const std::string& path, const std::string& digest = "");

// displaced_mesh() then write_mesh() to options.out. dst receives a copy of
// `height` (the command line's --mesh leaves it on the stack).
RELIEF_API bool mesh(OIIO::ImageBuf& dst, const OIIO::ImageBuf& height, const MeshOptions& options);

// Why `path` cannot take a mesh ("" when it can): its folder must exist and
// its extension be .obj, .ply, .gltf or .glb.
RELIEF_API std::string mesh_path_problem(const std::string& path);

}  // namespace relief
