#pragma once
// Stage 1, DDM derivation (DESIGN.md §4.1): normals -> slopes on the device.
#include <cstdint>
#include <memory>
#include <string>

#include "compute_context.h"

namespace relief::host {

// A slope field resident on a device: 2 floats (gx, gy) per texel, row-major.
// Opaque so that callers outside host/ never see OpenCL types.
class DeviceSlopes {
public:
    struct Impl;
    DeviceSlopes(int width, int height, std::shared_ptr<Impl> impl)
        : width_(width), height_(height), impl_(std::move(impl)) {}
    int width() const { return width_; }
    int height() const { return height_; }
    Impl& impl() const { return *impl_; }

private:
    int width_, height_;
    std::shared_ptr<Impl> impl_;
};

enum class GreenConvention { Auto, OpenGL, DirectX };

struct SlopeParams {
    int width = 0, height = 0;
    int channels = 3;        // 2 (x, y; z reconstructed) or 3 values per texel
    float scale = 2.0f;      // decoded = stored * scale + bias (UNORM: 2v - 1)
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

// Below this ratio of the two curl norms the choice is a guess (DESIGN §3).
constexpr double kAmbiguousCurlRatio = 1.15;

// Decodes `normals` (width*height*channels floats, as read from the image)
// and derives the slope field on the device.
DeviceSlopes derive_slopes(ComputeContext& ctx, const float* normals, const SlopeParams& params,
                           SlopeStats& stats);

// Puts a given slope field (2 floats per texel) on the device.
DeviceSlopes upload_slopes(ComputeContext& ctx, const float* slopes, int width, int height);

// Copies the field back: 2 floats per texel.
void read_slopes(ComputeContext& ctx, const DeviceSlopes& slopes, float* out);

} // namespace relief::host
