// SPDX-License-Identifier: Apache-2.0
#pragma once
// Accuracy against a true height whose scale and offset are unknown (real
// maps): the best affine fit a*est + b in the least-squares sense, and the
// error left after it (docs/design.md §5). Tests and benches share it, so
// their numbers are the same measure.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace relief::test {

struct AffineFit {
    double a = 0;            // the fitted scale (0 where est is constant)
    double rmse = 0;         // of a*est + b - truth, in truth's units
    double truth_std = 0;    // truth's standard deviation
    double truth_range = 0;  // truth's max - min
};

template <class E, class T>
AffineFit affine_fit(const std::vector<E>& est, const std::vector<T>& truth)
{
    AffineFit f;
    if (est.empty() || est.size() != truth.size())
        return f;
    const double n = double(est.size());
    double me = 0, mt = 0;
    for (std::size_t i = 0; i < est.size(); ++i) {
        me += double(est[i]);
        mt += double(truth[i]);
    }
    me /= n;
    mt /= n;
    double see = 0, set = 0, stt = 0;
    for (std::size_t i = 0; i < est.size(); ++i) {
        const double e = double(est[i]) - me, t = double(truth[i]) - mt;
        see += e * e;
        set += e * t;
        stt += t * t;
    }
    f.a = see > 0 ? set / see : 0.0;
    double sse = 0, lo = double(truth[0]), hi = lo;
    for (std::size_t i = 0; i < est.size(); ++i) {
        const double r = f.a * (double(est[i]) - me) + mt - double(truth[i]);
        sse += r * r;
        lo = std::min(lo, double(truth[i]));
        hi = std::max(hi, double(truth[i]));
    }
    f.rmse = std::sqrt(sse / n);
    f.truth_std = std::sqrt(stt / n);
    f.truth_range = hi - lo;
    return f;
}

// The error after the fit as a fraction of truth's spread (max - min); 0
// for a flat truth.
template <class E, class T>
double nrmse_affine(const std::vector<E>& est, const std::vector<T>& truth)
{
    const AffineFit f = affine_fit(est, truth);
    return f.truth_range > 0 ? f.rmse / f.truth_range : 0.0;
}

// The error after the fit as a fraction of truth's standard deviation
// (the share of its variation the estimate does not explain); 0 for a flat
// truth.
template <class E, class T>
double nrmse_affine_std(const std::vector<E>& est, const std::vector<T>& truth)
{
    const AffineFit f = affine_fit(est, truth);
    return f.truth_std > 0 ? f.rmse / f.truth_std : 0.0;
}

}  // namespace relief::test
