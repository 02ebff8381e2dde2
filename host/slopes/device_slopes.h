// SPDX-License-Identifier: Apache-2.0
#pragma once
// A slope field on the device (what stage 1 makes and stage 2 integrates),
// and where an integration puts its result: low enough for the OpenCL
// objects' header (opencl_context.h) to complete it without a stage's.
#include <functional>
#include <memory>
#include <utility>

namespace relief::host {

// A slope field resident on a device: 2 floats (gx, gy) per texel, row-major.
// Opaque so that callers outside host/ never see OpenCL types.
class DeviceSlopes {
public:
    struct Impl;
    DeviceSlopes(int width, int height, std::shared_ptr<Impl> impl)
        : width_(width), height_(height), impl_(std::move(impl))
    {
    }
    int width() const { return width_; }
    int height() const { return height_; }
    Impl& impl() const { return *impl_; }
    // Lets go of the device buffer (freed once no queued work uses it).
    void release() { impl_.reset(); }

private:
    int width_, height_;
    std::shared_ptr<Impl> impl_;
};

// Where an integration stage puts its width*height floats of height: called
// once, when the result is ready on the device, so that the host memory for
// it is taken only after the stage's own grids have been freed.
using HeightSink = std::function<float*()>;

}  // namespace relief::host
