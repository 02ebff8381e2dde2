// SPDX-License-Identifier: Apache-2.0
#pragma once
// Stage 3, distortion correction (docs/design.md §4.5): a height map -> per-texel
// texture-coordinate offsets, by per-node descent with a line search (Brent's,
// golden-section or ternary) and over-relaxation (kernels/correct.cl), coarse
// to fine.
#include <functional>
#include <string>
#include <vector>

#include "device/compute_context.h"
#include "correct/correct_grid.h"
#include "relief/correct_types.h"

namespace relief::host {

struct CorrectParams {
    // World height = scale * stored height; the texture's width spans one
    // world unit and texels are square.
    double scale = 0.05;
    double theta = 5.0;        // area exponent, 0..20
    bool corner_nodes = true;  // nodes at texel corners (else centres)
    Periodic periodic{true};   // the axes along which the texture tiles (else fixed borders)
    // Fixation weights per texel (w: the texel stays within 1/w texels of
    // where it started), or null.
    const float* fix_weights = nullptr;
    int iterations = 0;  // per level; 0 = until the relative energy change < tolerance
    double tolerance = 2e-5;
    int max_iterations = 1000;  // per level, for iterations = 0
    int levels = 0;             // pyramid levels; 0 = down to 16 texels, 1 = single resolution
    // Nothing is corrected (zero offsets, no solve) when no triangle's
    // anisotropy s1/s2 - 1 or area ratio |s1 s2 - 1| exceeds this.
    double threshold = 1e-3;
    bool skip_tiles = true;  // skip tiles whose nodes cannot move (bit-identical result)
    // The choices of relief/correct_types.h, the public API's own.
    using Search = relief::CorrectSearch;  // the line search per node
    using Hats = relief::CorrectHats;
    using Global = relief::CorrectGlobal;
    Search search = Search::Brent;
    // Over-relaxation: a node moves relax x its searched step when that
    // lowers its fan energy too (1 = exact line-search steps).
    double relax = 1.5;
    // Recompute the energy every iteration instead of summing the moved
    // nodes' falls (always so for tolerances below 1e-6): the same moves,
    // for tests and comparisons.
    bool energy_each_iteration = false;
    // The finest level also stops once its next iteration's fall, shrinking
    // at the rate of the last ones, is predicted below the tolerance
    // (docs/design.md §4.5.3); off: it runs until a fall is below it (tests).
    bool predict_stop = true;
    // Hat moves (docs/design.md §4.5.3b): regions of nodes moved together
    // under bilinear hats of every scale, where the nodes alone converge
    // slowly (auto), every iteration (always: tests, comparisons) or never.
    Hats hats = Hats::Off;
    // Global steps (docs/design.md §4.5.3c): every node at once along the
    // multilevel-preconditioned negative gradient, where they pay more than
    // the nodes' own iterations (auto), after every iteration (always:
    // tests, comparisons) or never.
    Global global = Global::Auto;
    // After a corner solve, node iterations on the delivered mesh (docs/
    // design.md §4.5.3f): the texel-centre nodes, started from the means of
    // their corners, each moving only if the delivered mesh's energy falls.
    // 0: the output is the corner means.
    int polish = 2;
};

// The report's types are the public API's (relief/correct_types.h: plain
// data), so that the plugin passes them on as they are.
using DistortionStats = relief::DistortionSummary;  // mean, 95th percentile, max

struct CorrectLevel {
    int width = 0, height = 0;  // texels
    int iterations = 0;
    double energy_start = 0.0, energy_end = 0.0;
    bool converged = false;  // relative change fell below the tolerance
    long long tile_phases = 0, tile_phases_run = 0;
    // The level started from the previous level's offsets times this
    // (1, 0.75, 0.5, 0.25 or 0: the lowest energy; 0 at the coarsest).
    double start_factor = 0.0;
    int hat_sweeps = 0;    // sweeps of hat moves over every scale
    int global_steps = 0;  // global steps taken (kept: each lowered the energy)
    double seconds = 0.0;
};

// The polish of the delivered texel-centre mesh (CorrectParams::polish).
using CorrectPolish = relief::CorrectPolishReport;

struct CorrectReport {
    bool skipped = false;        // nothing to correct: zero offsets, no solve
    double energy_before = 0.0;  // finest level, zero offsets
    double energy_after = 0.0;   // the solved mesh's (corner nodes: before the polish)
    CorrectPolish polish;        // corner nodes, polish > 0
    DistortionStats anisotropy_before, anisotropy_after;  // s1/s2 per triangle
    DistortionStats area_before, area_after;              // s1 s2 per triangle
    std::vector<CorrectLevel> levels;                     // coarsest first
    int total_iterations() const;
};

using CorrectProgress = std::function<void(double)>;

// heights: w*h stored heights (row-major). offsets_out: 2*w*h floats, the
// offset (u, v) at every texel centre in texture units (1 = the width,
// height). Throws Error on bad parameters or device trouble.
void correct_distortion(ComputeContext& ctx, const float* heights, int w, int h, const CorrectParams& params,
                        float* offsets_out, CorrectReport* report = nullptr,
                        const CorrectProgress& progress = {});

// The polish of correct_distortion() (CorrectParams::polish; docs/design.md
// §4.5.3f) on given texel-centre offsets (float2 per texel, texture units;
// for corner nodes the means of the corners), in place: flipped triangles
// unflipped first, then p.polish iterations of the centre-node solver.
CorrectPolish polish_delivered_mesh(ComputeContext& ctx, const std::vector<float>& heights,
                                    const std::vector<float>& fix_weights, int w, int h,
                                    const CorrectParams& p, std::vector<float>& offsets);

// The energy and per-triangle statistics of given node offsets (float2 per
// node, texture units) on the finest grid: for tests and benchmarks that
// score offsets. Returns the total energy.
double correction_energy(ComputeContext& ctx, const float* heights, int w, int h, const CorrectParams& params,
                         const float* node_offsets, DistortionStats* anisotropy = nullptr,
                         DistortionStats* area = nullptr);

}  // namespace relief::host
