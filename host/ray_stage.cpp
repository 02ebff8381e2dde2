#include "ray_stage.h"

#include <algorithm>
#include <vector>

#include "errors.h"
#include "opencl_context.h"

namespace relief::host {

namespace {

struct PackedTables {
    std::vector<cl_int> dir_start;    // directions + 1
    std::vector<cl_int2> offsets;     // per segment
    std::vector<cl_float4> data;      // (ext x, ext y, weight, cumulative weight)
};

PackedTables pack_tables(const RayParams& p)
{
    PackedTables t;
    for (double angle : ray_angles(p.rays, p.phase, p.directions)) {
        t.dir_start.push_back(cl_int(t.offsets.size()));
        double cumulative = 0.0;
        for (const RaySegment& s : walk_ray(angle, p.radius)) {
            cumulative += s.weight;
            t.offsets.push_back(cl_int2{{s.ox, s.oy}});
            t.data.push_back(cl_float4{{float(s.ext_x), float(s.ext_y), float(s.weight),
                                        float(cumulative)}});
        }
    }
    t.dir_start.push_back(cl_int(t.offsets.size()));
    return t;
}

template <class T>
cl::Buffer constant_buffer(cl::Context& ctx, std::vector<T>& v)
{
    return cl::Buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(T) * v.size(),
                      v.data());
}

} // namespace

void integrate_rays_reference(ComputeContext& ctx, const DeviceSlopes& slopes,
                              const RayParams& p, float* height_out, const Progress& progress)
{
    if (p.rays < 1 || !(p.radius > 0.0))
        throw Error("ray integration needs rays >= 1 and radius > 0");
    const int w = slopes.width(), h = slopes.height();
    const std::size_t n = std::size_t(w) * std::size_t(h);
    auto& c = ctx.impl();
    std::lock_guard<std::mutex> lock(c.mutex);
    try {
        PackedTables t = pack_tables(p);
        cl::Buffer dir_start = constant_buffer(c.context, t.dir_start);
        cl::Buffer offsets = constant_buffer(c.context, t.offsets);
        cl::Buffer data = constant_buffer(c.context, t.data);
        cl::Buffer out(c.context, CL_MEM_WRITE_ONLY, sizeof(float) * n);

        cl::Kernel k(c.program("rays_reference.cl"), "rays_reference");
        k.setArg(0, slopes.impl().buffer);
        k.setArg(1, w);
        k.setArg(2, h);
        k.setArg(5, cl_int(p.boundary == RayBoundary::Periodic));
        k.setArg(6, cl_int(p.rays));
        k.setArg(7, dir_start);
        k.setArg(8, offsets);
        k.setArg(9, data);
        k.setArg(10, out);

        // Launch in bands of rows: each launch stays short (GPU watchdogs,
        // responsive progress) whatever the radius.
        const double work_per_row = double(w) * double(std::max<std::size_t>(t.offsets.size(), 1));
        const int band = int(std::clamp(2.0e8 / work_per_row, 1.0, double(h)));
        for (int row0 = 0; row0 < h; row0 += band) {
            const int rows = std::min(band, h - row0);
            k.setArg(3, row0);
            k.setArg(4, rows);
            c.queue.enqueueNDRangeKernel(k, cl::NullRange,
                                         cl::NDRange(padded(std::size_t(w) * rows)),
                                         cl::NDRange(kGroupSize));
            if (progress) {
                c.queue.finish();
                progress(double(row0 + rows) / h);
            }
        }
        c.queue.enqueueReadBuffer(out, CL_TRUE, 0, sizeof(float) * n, height_out);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error in the ray stage: ") + e.what() + " (" +
                    std::to_string(e.err()) + ")");
    }

    // Zero mean, summed in a fixed order (deterministic whatever the threads).
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i)
        sum += height_out[i];
    const float mean = float(sum / double(n));
    for (std::size_t i = 0; i < n; ++i)
        height_out[i] -= mean;
}

} // namespace relief::host
