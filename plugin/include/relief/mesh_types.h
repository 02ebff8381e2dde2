// SPDX-License-Identifier: Apache-2.0
#pragma once
// The mesh and the options of displaced_mesh() and mesh() (mesh.h): plain
// data, no OpenImageIO.
#include <cstdint>
#include <string>
#include <vector>

#include "check_types.h"

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

}  // namespace relief
