// SPDX-License-Identifier: Apache-2.0
#pragma once
// Stage 1, DDM derivation (docs/design.md §4.1): normals -> slopes on the device.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "device/compute_context.h"
#include "slopes/device_slopes.h"

namespace relief::host {

enum class GreenConvention { Auto, OpenGL, DirectX };

struct SlopeParams {
    int width = 0, height = 0;
    int channels = 3;    // 2 (x, y; z reconstructed) or 3 values per texel
    float scale = 2.0f;  // decoded = stored * scale + bias (UNORM: 2v - 1)
    float bias = -1.0f;
    // Decoded x, y with |value| <= zero_band become exactly 0: for n-bit UNORM
    // maps 1/(2^n - 1), the codes either side of the midpoint. 0 for float.
    float zero_band = 0.0f;
    GreenConvention convention = GreenConvention::Auto;
    double max_angle_deg = 85.0;  // grazing clamp, from +z
};

struct SlopeStats {
    GreenConvention chosen = GreenConvention::OpenGL;
    bool auto_chosen = false;   // the convention was picked by the curl test
    bool ambiguous = false;     // auto: curl ratio under kAmbiguousCurlRatio
    double curl_opengl = 0.0;   // RMS curl per cell under each convention
    double curl_directx = 0.0;  // (computed only for Auto)
    std::int64_t invalid = 0;   // NaN/Inf/zero-length normals made flat
    std::int64_t clamped = 0;   // grazing normals clamped to max_angle
};

// Below this ratio of the two curl norms the choice is a guess (docs/design.md §3).
constexpr double kAmbiguousCurlRatio = 1.15;

// Derives the slope field on the device from the decoded normal map
// (width*height*channels floats), supplied a band of rows at a time:
// `rows(first_row, row_count, out)` writes row_count*width*channels floats.
// Only one band is ever held, so a map kept in its file's type (a byte per
// channel) is never widened to floats as a whole.
using NormalRows = std::function<void(int first_row, int row_count, float* out)>;
DeviceSlopes derive_slopes(ComputeContext& ctx, const NormalRows& rows, const SlopeParams& params,
                           SlopeStats& stats);

// Puts a given slope field (2 floats per texel) on the device.
DeviceSlopes upload_slopes(ComputeContext& ctx, const float* slopes, int width, int height);

// Copies the field back: 2 floats per texel.
void read_slopes(ComputeContext& ctx, const DeviceSlopes& slopes, float* out);

// Calls `use` with the field readable on the host (2 floats per texel) for
// the duration of the call: mapped, so a CPU device lends its own memory
// rather than a second copy.
void with_slopes_on_host(ComputeContext& ctx, const DeviceSlopes& slopes,
                         const std::function<void(const float*)>& use);

}  // namespace relief::host
