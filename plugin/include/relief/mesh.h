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

#include "relief/check.h"
#include "relief/export.h"

namespace relief {

struct Mesh {
    // Per vertex: (x, y, z) with x, y in texels over [0, W] x [0, H] (the
    // image's corners; y down the rows) and z = S * the height bilinear at
    // (x, y); the unit normal (-dz/dx, -dz/dy, 1)/|.|; texture coordinates
    // (x/W, 1 - y/H) (OBJ and PLY; glTF files store (x/W, y/H), glTF's
    // texture origin being the image's top-left: the same texel).
    std::vector<float> positions, normals, texcoords;  // 3, 3, 2 per vertex
    // Three vertex indices per triangle, counter-clockwise seen from +z.
    std::vector<std::uint32_t> triangles;
    // Per patch (row-major, ceil(W/P) x ceil(H/P)): the level it was
    // tessellated at, and the largest |surface - S h| at its texel centres.
    std::vector<int> levels;
    std::vector<double> errors;
    int raised = 0;  // patches tessellated above their level to keep stitched edges within E
};

struct MeshOptions {
    TessellationOptions tessellation;  // patch, error, scale, exec
    std::string out;                   // the file: .obj, .ply, .gltf or .glb
    // Recorded in the file (OBJ/PLY comment, glTF asset.extras) for make-like
    // updates; read back by recorded_digest() (imageio.h).
    std::string digest;
};

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
