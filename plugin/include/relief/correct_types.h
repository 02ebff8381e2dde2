// SPDX-License-Identifier: Apache-2.0
#pragma once
// The options of correct() (relief/correct.h), its choices and its report:
// plain data, no OpenImageIO. The host's solver takes the choices and fills
// in the report as they are.
#include <string>
#include <vector>

#include "options.h"
#include "relief/export.h"

namespace relief {

// The line search along each node's descent direction: Brent's minimiser
// (parabolic steps, precision relative to the step), golden section (one
// energy evaluation per step) or ternary (two per step; the first
// implementation). The last two are kept for comparison.
enum class CorrectSearch { Brent, Golden, Ternary };
// Hat moves: the nodes under bilinear hats of every scale (radius 2, 4, ...
// nodes) move together, each hat along its own descent direction, which
// carries smooth error across a level in one sweep where single nodes pass
// it on a node per iteration. Auto: sweeps on levels the nodes alone would
// take long to converge (maps with cliffs), interleaved with the nodes'
// iterations as their falls per cost compare; always: every iteration
// (tests, comparisons); off (the default since global steps, which do
// their work for less): single nodes only. Off under fixation.
enum class CorrectHats { Auto, Off, Always };
// Global steps: every node at once along the energy's gradient summed over
// bilinear hats of every scale (a multilevel preconditioner), the step
// searched on the total energy within the first flip anywhere: smooth
// error across the whole level in one step. Auto: after the first
// iteration of each level, then while a step falls more per cost than the
// nodes' iteration; always: after every iteration (tests, comparisons);
// off: as before them. Off under fixation.
enum class CorrectGlobal { Auto, Off, Always };

// mean, 95th percentile and maximum over the triangles of the mesh
struct DistortionSummary {
    double mean = 0.0, p95 = 0.0, max = 0.0;
};

struct CorrectLevelReport {
    int width = 0, height = 0;  // texels
    int iterations = 0;
    double energy_start = 0.0, energy_end = 0.0;
    bool converged = false;
    double tiles_run = 1.0;  // fraction of tile updates not skipped
    double seconds = 0.0;
    // The level started from the coarser level's offsets times this (1,
    // 0.75, 0.5, 0.25 or 0, whichever had the lowest energy; 0 at the
    // coarsest level).
    double start_factor = 0.0;
    int hat_sweeps = 0;    // sweeps of hat moves over every scale (CorrectHats)
    int global_steps = 0;  // global steps taken (CorrectGlobal)
};

// The polish of the delivered mesh (CorrectOptions::polish).
struct CorrectPolishReport {
    // Triangles of the corner means' mesh found flipped, the moves that
    // unflipped them (each node towards its neighbours or deeper inside its
    // fan), and any left flipped.
    long long flipped = 0, flipped_left = 0;
    int repairs = 0;
    int iterations = 0;
    // The delivered texel-centre mesh's energy: the corner means', then the output's.
    double energy_start = 0.0, energy_end = 0.0;
    double seconds = 0.0;
};

struct CorrectReport {
    bool skipped = false;                    // nothing could distort: zero offsets, no solve
    std::string boundary;                    // "periodic", "fixed" or x's,y's ("periodic,fixed"), as chosen
    std::string nodes;                       // "corner" or "center"
    double scale = 0.0;                      // the displacement scale used
    double energy_before = 0.0;              // at zero offsets
    double energy_after = 0.0;               // of the solved mesh (corner nodes: before the polish)
    CorrectPolishReport polish;              // nodes=corner with polish > 0
    int iterations = 0;                      // over all levels
    std::vector<CorrectLevelReport> levels;  // coarsest first
    DistortionSummary anisotropy_before, anisotropy_after;  // s1/s2
    DistortionSummary area_before, area_after;              // s1 s2 (3D area / texture area)
    double seconds = 0.0;
    int width = 0, height = 0;

    RELIEF_API std::string to_json() const;  // the --report file
};

// Corner: nodes at texel corners with bilinear heights; the offset of a
// texel is the mean of its four corners' (the reference tool's default).
// Center: one node per texel centre, with the texel's height.
enum class CorrectNodes { Corner, Center };
// Periodic: the texture tiles along the axis (the mesh wraps). Fixed: the
// border nodes at the axis's two ends stay put. Auto: periodic when the
// height jumps across that axis's wrap seam no more than twice the mean jump
// between neighbouring texels; the choice is reported.
enum class CorrectBoundary { Auto, Periodic, Fixed };
// A boundary for each axis, as relief::Boundaries for height().
using CorrectBoundaries = PerAxis<CorrectBoundary>;
struct CorrectOptions {
    // World height = scale * stored height, the texture's width spanning one
    // world unit (square texels). 0 = auto: 1/width for relief's own height
    // maps (stored in texels), otherwise an error asking for a scale.
    float scale = 0.0f;
    float theta = 5.0f;  // area exponent, 0..20
    CorrectNodes nodes = CorrectNodes::Corner;
    CorrectBoundaries boundary = CorrectBoundary::Auto;
    // Fixation (optional): texels with weight w stay within 1/w texels of
    // where they started. Either channel 0 of `fix_mask` (same size, values
    // >= 0; not owned) or a tent over the stored height: w = max(0, 1 -
    // |h - fix_height| / fix_width) when fix_width > 0.
    const OIIO::ImageBuf* fix_mask = nullptr;
    float fix_height = 0.0f, fix_width = 0.0f;
    int iterations = 0;  // per pyramid level; 0 = auto (until the tolerance)
    // Auto stops when the relative energy change per pass over the nodes
    // (the node phases, or a global step) is below this; the finest level
    // also when its next change, shrinking at the rate of the last ones,
    // is predicted below it.
    float tolerance = 2e-5f;
    // Per level, for auto: node iterations, each hat sweep and global step
    // counted as the iterations it costs (2.5 a scale of hats, 0.5 a step).
    int max_iterations = 1000;
    int levels = 0;  // coarse-to-fine levels; 0 = auto (down to 16 texels), 1 = off
    // Nothing is corrected when no triangle's anisotropy s1/s2 - 1 or area
    // change |s1 s2 - 1| exceeds this (zero offsets, no solve).
    float threshold = 1e-3f;
    bool skip_tiles = true;  // skip tiles whose nodes cannot move (identical result)
    CorrectSearch search = CorrectSearch::Brent;
    // Over-relaxation factor in [1, 2): a node moves `relax` times its
    // searched step when that also lowers the energy (1 = plain steps).
    float relax = 1.5f;
    CorrectHats hats = CorrectHats::Off;
    CorrectGlobal global = CorrectGlobal::Auto;
    // nodes=corner: after the solve, node iterations on the delivered mesh
    // (the texel centres, started from the means of their four corners), each
    // move lowering its energy. 0: the output is the corner means.
    int polish = 2;
    CorrectReport* report = nullptr;  // filled when given
    Execution exec;
};

}  // namespace relief
