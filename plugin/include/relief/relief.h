// SPDX-License-Identifier: Apache-2.0
#pragma once
// relief: normal maps to displacement, as OpenCL kernels behind an
// ImageBufAlgo-style API. Every operation comes in two forms: one returns an
// ImageBuf, the other writes `dst` and returns bool; errors via geterror().
#include "relief/devices.h"
#include "relief/errors.h"
#include "relief/bake.h"
#include "relief/check.h"
#include "relief/correct.h"
#include "relief/height.h"
#include "relief/imageio.h"
#include "relief/output_files.h"
#include "relief/mesh.h"
#include "relief/operations.h"
#include "relief/options.h"
#include "relief/preview.h"
#include "relief/slopes.h"
#include "relief/udim.h"
#include "relief/validate.h"
#include "relief/version.h"
