// SPDX-License-Identifier: Apache-2.0
#pragma once
// Distortion correction's choices and its report (relief/correct.h): plain
// data, without image types, which the host's solver takes and fills in as
// they are.
#include <string>
#include <vector>

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

}  // namespace relief
