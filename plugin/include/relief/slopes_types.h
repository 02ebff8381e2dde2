// SPDX-License-Identifier: Apache-2.0
#pragma once
// The options of slopes() (slopes.h): plain data, no OpenImageIO.
#include "options.h"

namespace relief {

struct SlopeOptions {
    NormalDecoding normals;
    Execution exec;
};

}  // namespace relief
