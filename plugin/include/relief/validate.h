// SPDX-License-Identifier: Apache-2.0
#pragma once
// Whether a set of options can run: one check per operation, in the words
// of the command line. Every front end reaches it: the operations call it
// first, and the table (command line, C ABI, Python) after parsing
// modifiers. A host can call it to check options before any image is read.
#include <string>

#include "relief/bake.h"
#include "relief/check.h"
#include "relief/correct.h"
#include "relief/export.h"
#include "relief/height.h"
#include "relief/mesh.h"
#include "relief/preview.h"
#include "relief/slopes.h"

namespace relief {

// The first broken rule ("rays=0 must be an integer in [1, 4096]", "impl=fast
// needs directions=rational (or use impl=reference)"), or "" when there is
// none. Values are held to the ranges `relief --help` lists.
RELIEF_API std::string validate(const SlopeOptions& options);
RELIEF_API std::string validate(const HeightOptions& options);
RELIEF_API std::string validate(const CorrectOptions& options);
RELIEF_API std::string validate(const BakeOptions& options);
RELIEF_API std::string validate(const NormalsOptions& options);
RELIEF_API std::string validate(const TessellationOptions& options);
RELIEF_API std::string validate(const MeshOptions& options);
RELIEF_API std::string validate(const PreviewOptions& options);

}  // namespace relief
