// SPDX-License-Identifier: Apache-2.0
#include "correct/level_state.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "device/cancel.h"
#include "device/queue_wait.h"

namespace relief::host {

namespace {

// The line search's number in correct.cl (CORRECT_SEARCH).
int search_number(CorrectParams::Search s)
{
    switch (s) {
    case CorrectParams::Search::Ternary: return 0;
    case CorrectParams::Search::Golden: return 1;
    case CorrectParams::Search::Brent: return 2;
    }
    return 2;
}

// The stage's kernel files, joined in this order into one program.
const std::vector<std::string> kCorrectFiles = {"correct.cl", "correct_nodes.cl", "correct_global.cl",
                                                "correct_hats.cl"};

// The correction's program built for a level: fp64 sums where the device
// has them, the area exponent as a constant when it is whole (its powers
// unrolled), the quads per work-item and the line search.
cl::Program& level_program(ComputeContext::Impl& c, bool fp64, const CorrectParams& p, int nodes_per_item)
{
    const bool whole = p.theta == std::floor(p.theta);
    return c.program(kCorrectFiles, std::string(fp64 ? "-DRELIEF_FP64" : "") +
                                        (whole ? " -DCORRECT_ITHETA=" + std::to_string(int(p.theta)) : "") +
                                        " -DCORRECT_NODES=" + std::to_string(nodes_per_item) +
                                        " -DCORRECT_SEARCH=" + std::to_string(search_number(p.search)));
}

}  // namespace

LevelState::LevelState(ComputeContext& ctx, const NodeGrid& grid, const std::vector<float>& heights,
                       const std::vector<float>& fix_weights, const CorrectParams& params, int nodes_per_item)
    : c(ctx.impl()), g(grid), p(params), fp64(ctx.fp64()), nodes(std::size_t(grid.nx) * grid.ny),
      use_fix(!fix_weights.empty()), program(level_program(c, fp64, params, nodes_per_item))
{
    energy_k_ = cl::Kernel(program, "correct_energy");
    gain_sum_k_ = cl::Kernel(program, "correct_gain_sum");
    energy_group_ = sum_group(energy_k_);
    gain_group_ = sum_group(gain_sum_k_);
    const std::size_t groups = std::max((nodes + kSumNodes * energy_group_ - 1) / (kSumNodes * energy_group_),
                                        (nodes + kSumNodes * gain_group_ - 1) / (kSumNodes * gain_group_));
    offsets = c.buffer(CL_MEM_READ_WRITE, sizeof(cl_float2) * nodes, "distortion correction");
    z = c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * nodes, "distortion correction",
                 heights.data());
    fix = use_fix ? c.buffer(CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(float) * nodes,
                             "distortion correction", fix_weights.data())
                  : c.buffer(CL_MEM_READ_ONLY, sizeof(float), "distortion correction");
    partial_ = c.buffer(CL_MEM_READ_WRITE, sum_size() * groups, "distortion correction");
    gain = c.buffer(CL_MEM_READ_WRITE, sum_size() * nodes, "distortion correction");
}

void LevelState::upload(const std::vector<float>& values)
{
    write_asking(c.queue, offsets, 0, sizeof(cl_float2) * nodes, values.data());
}

void LevelState::download(std::vector<float>& values)
{
    values.resize(2 * nodes);
    read_asking(c.queue, offsets, 0, sizeof(cl_float2) * nodes, values.data());
}

double LevelState::energy_of(const cl::Buffer& at, std::vector<float>* aniso, std::vector<float>* area)
{
    const bool want = aniso != nullptr;
    const std::size_t group = energy_group_, per_group = kSumNodes * group;
    std::size_t chunk = round_up(nodes, per_group);
    if (want) {
        aniso->clear();
        area->clear();
        const std::size_t fit = c.buffer_limit() / sizeof(cl_float4) / per_group * per_group;
        chunk = std::min(chunk, std::max(fit, per_group));
    }
    cl::Buffer stats = c.buffer(CL_MEM_WRITE_ONLY, want ? sizeof(cl_float4) * chunk : 16,
                                "distortion correction's statistics");
    // Room for every triangle up front (growing the vectors cost 13 ms
    // of a 1024^2 map's 30), so nothing reallocates or throws while the
    // buffer is mapped.
    if (want) {
        aniso->reserve(2 * nodes);
        area->reserve(2 * nodes);
    }
    double sum = 0.0;
    for (std::size_t first = 0; first < nodes; first += chunk) {
        const std::size_t count = std::min(chunk, round_up(nodes - first, per_group));
        set_args(energy_k_, at, z, fix, cl_int(use_fix), cl_int(g.nx), cl_int(g.ny),
                 cl_int(g.periodic.bits()), float(p.theta), partial_, cl::Local(sum_size() * group), stats,
                 cl_int(want), cl_int(first));
        stop_if_cancelled();
        c.queue.enqueueNDRangeKernel(energy_k_, cl::NullRange, cl::NDRange(count / kSumNodes),
                                     cl::NDRange(group));
        add_partials(partial_, count / per_group, sum);
        if (want) {
            // Mapped, not read into a copy: a CPU device hands over its
            // own memory.
            const std::size_t real = std::min(count, nodes - first);
            const auto* st =
                static_cast<const float*>(map_for_reading_asking(c.queue, stats, sizeof(cl_float4) * real));
            for (std::size_t i = 0; i < 4 * real; i += 2)
                if (!std::isnan(st[i])) {
                    aniso->push_back(st[i]);
                    area->push_back(st[i + 1]);
                }
            c.queue.enqueueUnmapMemObject(stats, const_cast<float*>(st));
        }
    }
    return sum;
}

double LevelState::gain_sum()
{
    set_args(gain_sum_k_, gain, cl_int(nodes), partial_, cl::Local(sum_size() * gain_group_));
    stop_if_cancelled();
    const std::size_t items = round_up((nodes + kSumNodes - 1) / kSumNodes, gain_group_);
    c.queue.enqueueNDRangeKernel(gain_sum_k_, cl::NullRange, cl::NDRange(items), cl::NDRange(gain_group_));
    double sum = 0.0;
    add_partials(partial_, items / gain_group_, sum);
    return sum;
}

void LevelState::clear_gains()
{
    if (fp64)
        c.fill(gain, cl_double(0), 0, sizeof(double) * nodes);
    else
        c.fill(gain, cl_float(0), 0, sizeof(float) * nodes);
}

void LevelState::add_partials(const cl::Buffer& partials, std::size_t groups, double& sum)
{
    if (fp64) {
        std::vector<double> part(groups);
        read_each_iteration(partials, sizeof(double) * groups, part.data());
        for (double v : part)
            sum += v;
    } else {
        std::vector<float> part(groups);
        read_each_iteration(partials, sizeof(float) * groups, part.data());
        for (float v : part)
            sum += v;
    }
}

void LevelState::read_each_iteration(const cl::Buffer& buffer, std::size_t bytes, void* dst)
{
    if (nodes >= kListenFrom)
        read_asking(c.queue, buffer, 0, bytes, dst);
    else
        c.queue.enqueueReadBuffer(buffer, CL_TRUE, 0, bytes, dst);
}

}  // namespace relief::host
