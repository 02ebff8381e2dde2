// SPDX-License-Identifier: Apache-2.0
#pragma once
// What one coarse-to-fine level of distortion correction keeps on the device
// (docs/design.md §4.5; kernels/correct.cl): the node offsets, heights and
// fixation weights, the program built for the level, and the reductions
// that the node phases (level_solver.h), the hat sweeps (hat_sweep.h) and
// the global steps (global_step.h) share: the energy, the nodes' summed
// falls and the partial sums behind both.
#include <cstddef>
#include <vector>

#include "correct/correct_grid.h"
#include "correct/correct_stage.h"
#include "device/opencl_context.h"

namespace relief::host {

// Nodes per work-item of the energy, gain and dot sums, CORRECT_SUM_NODES
// in correct.cl.
inline constexpr std::size_t kSumNodes = 8;

class LevelState {
public:
    // `nodes_per_item`: CORRECT_NODES, the quads a work-item of the phases
    // searches in lockstep.
    LevelState(ComputeContext& ctx, const NodeGrid& g, const std::vector<float>& z,
               const std::vector<float>& fix, const CorrectParams& p, int nodes_per_item);

    // Offsets in texels of this level (float2 per node).
    void upload(const std::vector<float>& c);
    void download(std::vector<float>& c);

    // The total energy of `offsets` (float2 per node, texels); with `aniso`
    // and `area`, per owned triangle its anisotropy and area ratio. The
    // statistics (16 bytes per node) come in chunks of at most one device
    // buffer; the partial sums are added in the same order whatever the
    // chunking.
    double energy_of(const cl::Buffer& offsets, std::vector<float>* aniso = nullptr,
                     std::vector<float>* area = nullptr);
    // The energy fall of the last pass: the sum of the nodes' gains.
    double gain_sum();
    void clear_gains();
    // Adds the first `groups` work-group partial sums of `partials` to
    // `sum`, in order.
    void add_partials(const cl::Buffer& partials, std::size_t groups, double& sum);
    // The reads each iteration makes (partial sums, active tiles). On a
    // level of at least kListenFrom nodes they listen (read_asking): a
    // kernel there runs tens of ms, and a blocking read behind it had kept
    // the host from hearing progress for 100 ms and more at 1024^2. On
    // smaller levels they block: they come a few ms apart, and the
    // listening wait's callback cost 15% at 512^2.
    void read_each_iteration(const cl::Buffer& buffer, std::size_t bytes, void* dst);
    static constexpr std::size_t kListenFrom = std::size_t(1) << 19;
    // Bytes of one partial sum (energy_t: double with fp64, else float).
    std::size_t sum_size() const { return fp64 ? sizeof(double) : sizeof(float); }
    // A work-group for a sum kernel: one energy_t of local memory per
    // work-item.
    std::size_t sum_group(const cl::Kernel& k) { return c.group_size(k, sum_size()); }

    ComputeContext::Impl& c;
    const NodeGrid g;
    const CorrectParams& p;
    const bool fp64;
    const std::size_t nodes;
    const bool use_fix;
    cl::Program& program;  // correct*.cl, built for this level's options
    cl::Buffer offsets;    // float2 per node, texels
    cl::Buffer z, fix;     // per node: height in texels, fixation weight
    cl::Buffer gain;       // per node: its last fall (energy_t)

private:
    cl::Kernel energy_k_, gain_sum_k_;
    std::size_t energy_group_ = 1, gain_group_ = 1;
    cl::Buffer partial_;  // per work-group of the energy or gain sum
};

}  // namespace relief::host
