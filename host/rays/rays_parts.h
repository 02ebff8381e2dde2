// SPDX-License-Identifier: Apache-2.0
#pragma once
// The pieces of radial ray integration (rays_stage.h) that its files share;
// included only by host/rays/*.cpp. rays_stage.cpp chooses
// the path; rays_reference.cpp walks every ray (rays_reference.cl);
// rays_fft.cpp integrates by one FFT convolution (rays_fft.cl); rays_fast.cpp
// walks the rational directions' chains (rays_fast.cl); tiles.cpp finds
// the tiles that cannot be skipped (tiles.cl).
#include <functional>
#include <vector>

#include "errors.h"
#include "device/opencl_context.h"
#include "rays/rays_stage.h"

namespace relief::host {

// What every ray integrator needs (relief::validate() checks the options).
inline void expect_ray_params(const RayParams& p)
{
    expects(p.rays >= 1 && p.radius > 0.0, "RayParams: rays >= 1 and radius > 0");
}

// Calls fn(j, offsets, data) with direction j's packed walk, one direction
// at a time: all directions' walks at once reached ~25 GB at rays=4096,
// radius=65536.
using PackedWalkFn =
    std::function<void(int j, const std::vector<cl_int2>& offsets, const std::vector<cl_float4>& data)>;
void for_each_packed_direction(const RayParams& p, const PackedWalkFn& fn);

// A read-only device copy of a host table (walks, periods, chain starts).
template <class T>
cl::Buffer constant_buffer(ComputeContext::Impl& c, std::vector<T>& v)
{
    return c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(T) * v.size(),
                    "ray integration's walk tables", v.data());
}

// One flag per kSkipTile^2 tile: 1 where the rays of its texels may cross a
// non-zero slope (a non-flat tile within `reach` texels), 0 where they cannot.
cl::Buffer active_tiles(ComputeContext::Impl& c, const DeviceSlopes& slopes, double reach, bool periodic,
                        bool skip, int& tiles_x, RayReport& report);

// A = Kx (x) gx + Ky (x) gy, one circular convolution: the periodic
// result before its mean is removed, and the clip result wherever every ray
// stays in the image. The caller holds c.mutex. With `consume`, the slopes
// are let go once split into the transform's grids; the host memory for
// the result is asked of `sink` only after the grids are gone.
void fft_ray_sums(ComputeContext::Impl& c, DeviceSlopes& slopes, bool consume, const RayParams& p,
                  const HeightSink& sink, const Progress& progress);

// Periodic boundaries: the convolution, then the mean removed.
void integrate_rays_by_fft(ComputeContext& ctx, DeviceSlopes& slopes, bool consume, const RayParams& p,
                           const HeightSink& sink, const Progress& progress, RayReport* report);

// Rational directions along chain windows (clip, or periodic without the
// FFT): with clip_by_fft, the FFT's values where every ray stays inside and
// chains in the border band only.
void integrate_rays_chains(ComputeContext& ctx, const DeviceSlopes& slopes, const RayParams& p,
                           float* height_out, const Progress& progress, RayReport* report);

}  // namespace relief::host
