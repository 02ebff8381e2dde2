// SPDX-License-Identifier: Apache-2.0
// Distortion correction: when a level stops: the tolerance per pass, the predicted stop,
// max_iterations.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <utility>

#include "device/compute_context.h"
#include "correct/correct_grid.h"
#include "correct/correct_stage.h"
#include "correct/correct_stop_rule.h"
#include "reference/correct_reference.h"
#include "relief/correct.h"
#include "relief/errors.h"
#include "support/fields.h"
#include "support/images.h"
#include "correct/correct_test.h"

using namespace relief;
using namespace relief::test::correction;

namespace {

// The stop rule's tests: one level, a global step every iteration (two
// passes over the nodes an iteration), no hats.
host::CorrectParams stop_rule_params(double tolerance)
{
    auto p = params(0.5, host::Periodic(true));
    p.levels = 1;
    p.threshold = 0.0;
    p.hats = host::CorrectParams::Hats::Off;
    p.global = host::CorrectParams::Global::Always;
    p.tolerance = tolerance;
    return p;
}

// e[k], the energy after exactly k iterations of `p`, for k from `first`
// to `last` (the others 0).
std::vector<double> energies_after(const std::vector<float>& hts, int w, int h, host::CorrectParams p,
                                   int first, int last)
{
    std::vector<double> e(last + 1, 0.0);
    for (int k = first; k <= last; ++k) {
        host::CorrectReport r;
        p.iterations = k;
        run(hts, w, h, p, &r);
        e[k] = r.energy_after;
    }
    return e;
}

}  // namespace

TEST_CASE("correct: the tolerance bounds the fall per pass over the nodes", "[correct]")
{
    // global=always: an iteration is its node phases and a global step, two
    // passes over the nodes, so auto stops at the first iteration that falls by
    // less than twice the tolerance (relative), not once it. The energies
    // after k iterations come from runs of iterations=k (the same bits up
    // to there).
    const int w = 48, h = 40;
    const auto hts = waves(w, h, 1.0, 24);
    const double tol = 1e-4;
    auto p = stop_rule_params(tol);
    p.predict_stop = false;  // the next test's
    host::CorrectReport rep;
    run(hts, w, h, p, &rep);
    REQUIRE(rep.levels.size() == 1);
    const int n = rep.levels[0].iterations;
    REQUIRE(rep.levels[0].converged);
    REQUIRE(n >= 3);
    const std::vector<double> e = energies_after(hts, w, h, p, n - 2, n);
    const auto fall = [&](int k) { return (e[k - 1] - e[k]) / e[k - 1]; };
    INFO("stopped after " << n << " iterations; falls " << fall(n - 1) << " then " << fall(n));
    CHECK(std::abs(e[n] - rep.energy_after) <= 1e-9 * e[n]);
    CHECK(fall(n) < 2 * tol);
    CHECK(fall(n - 1) >= 2 * tol);
}

TEST_CASE("correct: a tolerance below 1e-6 takes the energy itself every iteration", "[correct]")
{
    // The energy tracked by the nodes' falls is exact to about 1e-7 of it:
    // below 1e-6 a level must compute it each iteration, and then runs as
    // energy_each_iteration does, bit for bit (the global steps start their
    // search from it).
    const int w = 48, h = 40;
    const auto hts = waves(w, h, 1.0, 24);
    auto p = stop_rule_params(1e-7);
    p.max_iterations = 8;
    host::CorrectReport tracked, each;
    const auto a = run(hts, w, h, p, &tracked);
    p.energy_each_iteration = true;
    const auto b = run(hts, w, h, p, &each);
    REQUIRE(tracked.levels.size() == 1);
    CHECK(tracked.levels[0].global_steps > 0);
    CHECK(tracked.levels[0].iterations == each.levels[0].iterations);
    CHECK(tracked.levels[0].energy_end == each.levels[0].energy_end);
    CHECK(a == b);
}

TEST_CASE("correct: the finest level stops once the next fall is predicted below the tolerance", "[correct]")
{
    // As the test before, with the prediction but without global steps
    // (their quasi-Newton directions make the last falls differ between
    // devices more than the rule's margins here): falls f(k) per pass (one
    // an iteration), rates r(k) = f(k) / f(k-1). The level stops after the
    // first iteration n at which f(n) < tol, or f(n) < f(n-1) < f(n-2) and
    // f(n) max(r(n), min(1, 2 r(n) - r(n-1))) < tol; here the prediction,
    // not the fall, must stop it.
    const int w = 48, h = 40;
    const auto hts = waves(w, h, 1.0, 24);
    const double tol = 1e-4;
    auto p = stop_rule_params(tol);
    p.global = host::CorrectParams::Global::Off;
    host::CorrectReport rep, plain;
    run(hts, w, h, p, &rep);
    auto q = p;
    q.predict_stop = false;
    run(hts, w, h, q, &plain);
    REQUIRE(rep.levels.size() == 1);
    const int n = rep.levels[0].iterations, m = plain.levels[0].iterations;
    REQUIRE(rep.levels[0].converged);
    REQUIRE(n >= 4);
    std::vector<double> e = energies_after(hts, w, h, p, std::max(1, n - 4), n);
    e[0] = rep.levels[0].energy_start;
    const auto f = [&](int k) { return (e[k - 1] - e[k]) / e[k - 1]; };
    const auto stops = [&](int k) {
        if (f(k) < tol)
            return true;
        if (!(f(k) < f(k - 1) && f(k - 1) < f(k - 2)))
            return false;
        const double rate = f(k) / f(k - 1), last = f(k - 1) / f(k - 2);
        return f(k) * std::max(rate, std::min(1.0, 2.0 * rate - last)) < tol;
    };
    INFO("stopped after " << n << " iterations (" << m << " without the prediction); falls per pass "
                          << f(n - 2) << ", " << f(n - 1) << ", " << f(n));
    CHECK(n < m);
    CHECK(std::abs(e[n] - rep.energy_after) <= 1e-9 * e[n]);
    CHECK(f(n) >= tol);
    CHECK(stops(n));
    CHECK_FALSE(stops(n - 1));
}

TEST_CASE("correct: the predicted stop compares only iterations of the same work", "[correct]")
{
    // Tolerance 1e-5; falls per pass of three iterations, oldest first, and
    // the passes each made. The next fall is predicted as the last times
    // max(r, min(1, 2r - r')), r and r' the last two rates.
    const double tol = 1e-5;
    const auto predicts = [&](std::initializer_list<std::pair<double, double>> falls) {
        host::FallHistory h;
        for (const auto& [fall, passes] : falls)
            h.push(fall, passes);
        return h.predicts_below(tol);
    };
    // Rates 0.5 then 0.6: 1.2e-5 x 0.7 = 8.4e-6, a stop ...
    CHECK(predicts({{4e-5, 2}, {2e-5, 2}, {1.2e-5, 2}}));
    // ... but not when the last iteration added a global step (it divides
    // its fall by 3 passes, not 2) or the first made fewer passes.
    CHECK_FALSE(predicts({{4e-5, 2}, {2e-5, 2}, {1.2e-5, 3}}));
    CHECK_FALSE(predicts({{4e-5, 1}, {2e-5, 2}, {1.2e-5, 2}}));
    // Rates 0.75 then 0.67: 2e-5 x 0.67 = 1.3e-5, no stop.
    CHECK_FALSE(predicts({{4e-5, 2}, {3e-5, 2}, {2e-5, 2}}));
    CHECK_FALSE(predicts({{2e-5, 2}, {1.2e-5, 2}}));             // two rates needed
    CHECK_FALSE(predicts({{4e-5, 2}, {4e-5, 2}, {1.2e-5, 2}}));  // the falls must shrink
    // A rising rate, 0.69 then 0.88: the trend (1.07, capped at 1) keeps
    // the next fall at 1.1e-5; the last rate alone would predict 9.7e-6.
    CHECK_FALSE(predicts({{1.8e-5, 2}, {1.25e-5, 2}, {1.1e-5, 2}}));
    // A falling rate, 0.99 then 0.9: the last rate (1.08e-5), not the
    // trend's 0.81 (9.7e-6).
    CHECK_FALSE(predicts({{1.35e-5, 2}, {1.3333e-5, 2}, {1.2e-5, 2}}));
}

TEST_CASE("correct: max_iterations bounds a level's work, each hat sweep counted as the iterations it costs",
          "[correct]")
{
    // A steep 128^2 periodic map at one level, a tolerance it cannot reach
    // in 60 iterations' work: the sweeps (scales B = 2 to 32, 2.5
    // iterations each, so 12.5 a sweep) count towards the limit, and the
    // level stops at the first iteration that reaches it.
    const int n = 128;
    const auto big = waves(n, n, 1.0, 23);
    auto p = params(1.0, host::Periodic(true));
    p.levels = 1;
    p.hats = host::CorrectParams::Hats::Auto;
    p.global = host::CorrectParams::Global::Off;  // counted alike, tested apart
    p.max_iterations = 60;
    p.tolerance = 1e-9;
    host::CorrectReport rep;
    run(big, n, n, p, &rep);
    REQUIRE(rep.levels.size() == 1);
    const auto& l = rep.levels[0];
    INFO(l.iterations << " iterations, " << l.hat_sweeps << " sweeps");
    CHECK_FALSE(l.converged);
    CHECK(l.hat_sweeps > 0);
    const double spent = l.iterations + 12.5 * l.hat_sweeps;
    CHECK(spent >= 60.0);
    CHECK(spent < 61.0);
    // A fixed count is node iterations, sweeps or not.
    p.iterations = 7;
    p.hats = host::CorrectParams::Hats::Always;
    run(big, n, n, p, &rep);
    CHECK(rep.levels[0].iterations == 7);
    CHECK(rep.levels[0].hat_sweeps == 7);
}
