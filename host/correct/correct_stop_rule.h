// SPDX-License-Identifier: Apache-2.0
// The finest correction level's predicted stop (docs/design.md §4.5.3).
#pragma once

#include <algorithm>
#include <cmath>

namespace relief::host {

// The falls per pass over the nodes of a level's last three iterations,
// and the passes each made.
class FallHistory {
public:
    void push(double fall, double passes)
    {
        for (int k = 0; k < 2; ++k) {
            fall_[k] = fall_[k + 1];
            passes_[k] = passes_[k + 1];
        }
        fall_[2] = fall;
        passes_[2] = passes;
        count_ = std::min(count_ + 1, 3);
    }

    // Whether the next iteration's fall, shrinking at the rate of the last
    // ones, would be below the tolerance: a level whose falls shrink
    // geometrically then stops one iteration sooner, leaving a fall below
    // the tolerance undone (1024^2 wall: 8 iterations instead of 9, the
    // energy 7e-5 higher). Convergence slows as it goes (the wall's rate
    // rose from 0.12 to 0.70 per iteration), so a rising rate is taken as
    // the last plus its last change (at most 1). Nothing is predicted
    // before two rates are known, while the falls do not shrink, or across
    // iterations of different work: one that adds a global step or a hat
    // sweep divides its fall by more passes, which is no sign of
    // convergence.
    bool predicts_below(double tolerance) const
    {
        if (count_ < 3 || passes_[0] != passes_[2] || passes_[1] != passes_[2])
            return false;
        const double f0 = fall_[0], f1 = fall_[1], f2 = fall_[2];
        if (!(f2 > 0.0 && f2 < f1 && f1 < f0) || !std::isfinite(f0))
            return false;
        const double rate = f2 / f1, last = f1 / f0;
        return f2 * std::max(rate, std::min(1.0, 2.0 * rate - last)) < tolerance;
    }

private:
    double fall_[3] = {0.0, 0.0, 0.0}, passes_[3] = {0.0, 0.0, 0.0};  // oldest first
    int count_ = 0;
};

}  // namespace relief::host
