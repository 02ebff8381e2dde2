// SPDX-License-Identifier: Apache-2.0
// Radial ray integration, the reference kernel (docs/design.md §4.2;
// kernels/rays_reference.cl): every ray walked texel by texel, from one
// device table of all directions' walks.
#include <algorithm>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include "errors.h"
#include "field_ops.h"
#include "rays/rays_parts.h"
#include "device/queue_wait.h"
#include <sstream>

namespace relief::host {

void for_each_packed_direction(const RayParams& p, const PackedWalkFn& fn)
{
    const std::vector<double> dir_weight = angular_weights(ray_angles(p.rays, p.phase, p.directions));
    const std::vector<RationalDirection> rational = p.directions == DirectionSet::Rational
                                                        ? rational_directions(p.rays, p.phase)
                                                        : std::vector<RationalDirection>();
    const std::vector<double> angles = p.directions == DirectionSet::Rational
                                           ? std::vector<double>()
                                           : ray_angles(p.rays, p.phase, p.directions);
    std::vector<cl_int2> offsets;
    std::vector<cl_float4> data;
    for (int j = 0; j < p.rays; ++j) {
        const std::vector<RaySegment> walk = p.directions == DirectionSet::Rational
                                                 ? walk_rational_ray(rational[j], p.radius)
                                                 : walk_ray(angles[j], p.radius);
        offsets.clear();
        data.clear();
        double cumulative = 0.0;
        for (const RaySegment& s : walk) {
            const double weight = s.weight * dir_weight[j];
            cumulative += weight;
            offsets.push_back(cl_int2{{s.ox, s.oy}});
            data.push_back(cl_float4{{float(s.ext_x), float(s.ext_y), float(weight), float(cumulative)}});
        }
        fn(j, offsets, data);
    }
}

namespace {

struct PackedTables {
    std::vector<cl_int> dir_start;  // directions + 1
    std::vector<cl_int2> offsets;   // per segment
    std::vector<cl_float4> data;    // (ext x, ext y, weight, cumulative weight)
};

// An upper bound on the segments of all walks: a ray crosses at most
// |cos| + |sin| <= sqrt(2) texel edges per texel of length, plus its ends
// (and a rational walk splits one segment per period).
double walk_segments_bound(const RayParams& p)
{
    return double(p.rays) * (2.0 * std::sqrt(2.0) * p.radius + 4.0);
}

PackedTables pack_tables(ComputeContext::Impl& c, const RayParams& p)
{
    // The reference kernel reads every walk from one device table: refuse
    // what cannot be allocated before building it on the host.
    const double bytes = walk_segments_bound(p) * sizeof(cl_float4);
    if (bytes > double(c.buffer_limit()) || walk_segments_bound(p) > double(INT32_MAX))
        throw Error("rays=" + std::to_string(p.rays) + " and radius=" +
                    [&] {
                        std::ostringstream r;
                        r << p.radius;
                        return r.str();
                    }() +
                    " need walk tables of up to " +
                    std::to_string(int(std::ceil(bytes / (1024.0 * 1024.0)))) +
                    " MiB, more than the device allows in one buffer (" +
                    std::to_string(c.buffer_limit() / (1024 * 1024)) +
                    " MiB); use impl=fast, or fewer rays or a shorter radius");
    PackedTables t;
    for_each_packed_direction(
        p, [&](int, const std::vector<cl_int2>& offsets, const std::vector<cl_float4>& data) {
            t.dir_start.push_back(cl_int(t.offsets.size()));
            t.offsets.insert(t.offsets.end(), offsets.begin(), offsets.end());
            t.data.insert(t.data.end(), data.begin(), data.end());
        });
    t.dir_start.push_back(cl_int(t.offsets.size()));
    return t;
}

}  // namespace

void integrate_rays_reference(ComputeContext& ctx, const DeviceSlopes& slopes, const RayParams& p,
                              float* height_out, const Progress& progress, RayReport* report)
{
    expect_ray_params(p);
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        PackedTables t = pack_tables(c, p);
        // Each work-item walks every direction's segments in its own loops.
        if (!c.loops_fit(std::uint64_t(t.offsets.size()) + std::uint64_t(p.rays)))
            throw Error("impl=reference walks " + std::to_string(t.offsets.size()) +
                        " ray segments per texel, more than this device lets a work-item loop (it "
                        "stops loops after " +
                        std::to_string(c.loop_limit()) +
                        " iterations, as Mesa's llvmpipe does); use fewer rays, a shorter radius "
                        "or impl=fast");
        cl::Buffer dir_start = constant_buffer(c, t.dir_start);
        cl::Buffer offsets = constant_buffer(c, t.offsets);
        cl::Buffer data = constant_buffer(c, t.data);
        cl::Buffer out = c.buffer(CL_MEM_WRITE_ONLY, sizeof(float) * n, "ray integration");

        RayReport skipped;
        int tiles_x = 0;
        cl::Buffer active = active_tiles(c, slopes, p.radius + 2.0, p.boundary == RayBoundary::Periodic,
                                         p.skip_flat, tiles_x, skipped);
        if (report)
            *report = skipped;
        const bool fp64 = ctx.fp64() && !p.force_float;
        cl::Kernel k(c.program("rays_reference.cl", fp64 ? "-DRELIEF_FP64" : ""), "rays_reference");
        // Arguments 3 and 4, the band of rows, are set per launch.
        set_args(k, slopes.impl().buffer, w, h);
        set_args_at(k, 5, cl_int(p.boundary == RayBoundary::Periodic), cl_int(p.rays), dir_start, offsets,
                    data, active, cl_int(kSkipTile), cl_int(tiles_x), out);

        // Launch in bands of rows: each launch stays short (GPU watchdogs,
        // responsive progress and cancel) whatever the radius: 3e7 steps, 40
        // ms on two CPU cores (2e8 had been 272 ms between progress calls
        // at 1024^2, 16 rays of 64 texels).
        const double work_per_row = double(w) * double(std::max<std::size_t>(t.offsets.size(), 1));
        const int band = int(std::clamp(3.0e7 / work_per_row, 1.0, double(h)));
        for (int row0 = 0; row0 < h; row0 += band) {
            const int rows = std::min(band, h - row0);
            set_args_at(k, 3, row0, rows);
            c.launch(k, std::size_t(w) * rows);
            if (progress) {
                finish_asking(c.queue);
                progress(double(row0 + rows) / h);
            }
        }
        read_asking(c.queue, out, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw opencl_error("ray", e);
    }

    remove_mean(height_out, n);
}

}  // namespace relief::host
