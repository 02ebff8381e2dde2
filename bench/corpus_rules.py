#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Rules for relief's defaults, judged on maps they were not fitted on.

Usage: bench/corpus_rules.py [RESULTS_DIR]   (default bench/results)

Reads corpus_runs.csv and corpus_maps.csv (bench_corpus) and writes
corpus.md there: the error of every method per package and kind, the
default against the per-map best, and rules for the boundary and the
method fitted by leave-one-package-out cross-validation: each rule's
parameters are chosen on the other packages' maps (least mean NRMSE) and
scored on the package left out; the held-out scores of all packages
together are the rule's figure. Also corpus_time_error.png (gnuplot):
mean error against time per megatexel, one point per method.
"""
import csv
import itertools
import math
import os
import statistics
import subprocess
import sys

out = sys.argv[1] if len(sys.argv) > 1 else "bench/results"
runs = list(csv.DictReader(open(os.path.join(out, "corpus_runs.csv"))))
maps = {m["map"]: m for m in csv.DictReader(open(os.path.join(out, "corpus_maps.csv")))}
err, sec = {}, {}
for r in runs:
    key = (r["method"], r["boundary"], float(r["radius"]))
    err.setdefault(r["map"], {})[key] = float(r["nrmse"])
    sec.setdefault(r["map"], {})[key] = float(r["seconds"])
names = sorted(n for n in maps if n in err)
DEFAULT = ("default", "auto", 0.0)
LS = [("poisson", f"{a},{b}", 0.0) for a in ("free", "periodic") for b in ("free", "periodic")]
RADII = sorted({k[2] for n in names for k in err[n] if k[0] == "rays"})


def f(n, key):
    return float(maps[n][key])


def best_ls(n):
    return min(err[n][k] for k in LS)


def best_any(n):
    return min(err[n].values())


def mean(v):
    v = list(v)
    return sum(v) / len(v) if v else float("nan")


def gmean(v):
    v = [max(x, 1e-9) for x in v]
    return math.exp(sum(map(math.log, v)) / len(v)) if v else float("nan")


# --- rules -------------------------------------------------------------
def axis_tiles(n, axis, a, b):
    """An axis tiles when its seam correlates at least a times as well as
    neighbouring lines (and above the noise of a correlation, 2/sqrt(len)),
    or when block heights step at most b times as much across the seam."""
    length = f(n, "height") if axis == "x" else f(n, "width")
    seam, adjacent = f(n, axis + "_seam"), f(n, axis + "_adjacent")
    slopes = seam >= a * adjacent and seam > 2 / math.sqrt(length)
    return slopes or f(n, axis + "_height_step") <= b


def ls_key(n, a, b):
    x, y = axis_tiles(n, "x", a, b), axis_tiles(n, "y", a, b)
    return ("poisson", f"{'periodic' if x else 'free'},{'periodic' if y else 'free'}", 0.0)


def rays_key(n, radius, a, b):
    both = axis_tiles(n, "x", a, b) and axis_tiles(n, "y", a, b)
    return ("rays", "periodic" if both else "clip", radius)


BOUNDARY_GRID = [(a, b) for a in (0.3, 0.4, 0.5, 0.6, 0.7, 0.8) for b in (0.0, 1.25, 1.5, 2.0, 3.0, 1e9)]
FEATURES = ["slope_kurtosis", "flat_share"] + [f"coarse_share_{r:g}" for r in RADII]


def method_rules(boundary):
    """(description, chooser) for every method rule: rays at a radius where
    a feature is on one side of a threshold, least squares elsewhere."""
    a, b = boundary
    yield "least squares", lambda n: ls_key(n, a, b)
    for feature in FEATURES:
        values = sorted({f(n, feature) for n in names})
        cuts = sorted({values[int(q * (len(values) - 1))] for q in [i / 20 for i in range(1, 20)]})
        for radius, cut, below in itertools.product(RADII, cuts, (True, False)):
            def choose(n, feature=feature, radius=radius, cut=cut, below=below):
                rays = f(n, feature) < cut if below else f(n, feature) >= cut
                return rays_key(n, radius, a, b) if rays else ls_key(n, a, b)
            yield f"rays r={radius:g} where {feature} {'<' if below else '>='} {cut:.4g}", choose


def fit(train, rules):
    return min(rules, key=lambda rule: mean(err[n][rule[1](n)] for n in train))


def cross_validate(make_rules):
    """Held-out error per map, and the rule fitted on each package's complement."""
    packages = sorted({maps[n]["package"] for n in names})
    held, chosen = {}, {}
    for p in packages:
        train = [n for n in names if maps[n]["package"] != p]
        test = [n for n in names if maps[n]["package"] == p]
        desc, rule = fit(train, list(make_rules()))
        chosen[p] = desc
        for n in test:
            held[n] = err[n][rule(n)]
    return held, chosen


def boundary_rules():
    for a, b in BOUNDARY_GRID:
        yield f"a={a} b={b:g}", (lambda n, a=a, b=b: ls_key(n, a, b))


def combined_rules():
    for bnd in BOUNDARY_GRID:
        for desc, rule in method_rules(bnd):
            yield f"boundary a={bnd[0]} b={bnd[1]:g}; {desc}", rule


# --- report ------------------------------------------------------------
md = open(os.path.join(out, "corpus.md"), "w")
w = md.write
w("# Methods and defaults over the corpus\n\n")
w(f"{len(names)} maps from {len({maps[n]['package'] for n in names})} packages (bench_corpus, then "
  "bench/corpus_rules.py). Error: NRMSE after the best affine fit against the authored height "
  "(std-normalised). Best LS: the best of least squares's four per-axis boundaries for each map; "
  "best: the best of everything run.\n\n")
w("| group | maps | default | best LS | best | default / best LS (gmean) |\n|---|---|---|---|---|---|\n")
for label, group in [("all", names)] + [
        (f"package {p}", [n for n in names if maps[n]["package"] == p]) for p in sorted({maps[n]["package"] for n in names})] + [
        (f"kind {k}", [n for n in names if maps[n]["kind"] == k]) for k in sorted({maps[n]["kind"] for n in names})]:
    w(f"| {label} | {len(group)} | {mean(err[n][DEFAULT] for n in group):.3f} | {mean(best_ls(n) for n in group):.3f} "
      f"| {mean(best_any(n) for n in group):.3f} | {gmean(err[n][DEFAULT] / best_ls(n) for n in group):.3f} |\n")

w("\n## Every method: mean error and time\n\n| method | boundary | radius | mean NRMSE | median s per Mtexel |\n"
  "|---|---|---|---|---|\n")
points = []
for key in sorted({k for n in names for k in err[n]}):
    have = [n for n in names if key in err[n]]
    e = mean(err[n][key] for n in have)
    t = statistics.median(sec[n][key] / (f(n, "width") * f(n, "height") / 1e6) for n in have)
    points.append((key, e, t))
    w(f"| {key[0]} | {key[1]} | {key[2]:g} | {e:.3f} | {t:.3f} |\n")

held_b, chosen_b = cross_validate(boundary_rules)
w("\n## The boundary of least squares, cross-validated\n\n")
hits = sum(1 for n in names if held_b[n] <= max(1.05 * best_ls(n), best_ls(n) + 0.005))
w(f"Rule family: an axis tiles when its seam's slopes correlate at least a times as well as neighbouring "
  f"lines', or its block heights step at most b times as much across the seam (b = 0: slopes alone). "
  f"Held out (leave one package out): mean {mean(held_b.values()):.3f} against best LS "
  f"{mean(best_ls(n) for n in names):.3f}; within 5% (or 0.005) of best LS on {hits} of {len(names)} maps; "
  f"relief's current rule: mean {mean(err[n][DEFAULT] for n in names if maps[n]['default_method'] == 'poisson'):.3f} "
  f"on the maps it solves by least squares. Fitted per held-out package: "
  + "; ".join(f"{p}: {d}" for p, d in chosen_b.items()) + ".\n")

held_m, chosen_m = cross_validate(combined_rules)
w("\n## The method, cross-validated\n\n")
w(f"Rule family: the boundary rule above, and rays at radius r where one feature of the normals is on one "
  f"side of a threshold, least squares elsewhere. Held out: mean {mean(held_m.values()):.3f} "
  f"(per-map best of everything {mean(best_any(n) for n in names):.3f}, default today {mean(err[n][DEFAULT] for n in names):.3f}). "
  "Fitted per held-out package:\n\n")
for p, d in chosen_m.items():
    w(f"- {p}: {d}\n")
w("\n## Per map (held out)\n\n| map | package | kind | default | best LS | best | boundary rule | method rule |\n"
  "|---|---|---|---|---|---|---|---|\n")
for n in names:
    w(f"| {n} | {maps[n]['package']} | {maps[n]['kind']} | {err[n][DEFAULT]:.3f} | {best_ls(n):.3f} | "
      f"{best_any(n):.3f} | {held_b[n]:.3f} | {held_m[n]:.3f} |\n")
md.close()

dat = os.path.join(out, "corpus_time_error.dat")
with open(dat, "w") as d:
    for key, e, t in points:
        d.write(f"{t:.5f} {e:.5f} \"{key[0]} {key[1]}{' r=%g' % key[2] if key[2] else ''}\"\n")
gp = f"""set terminal pngcairo size 1000,700 font 'DejaVu Sans,13'
set output '{os.path.join(out, "corpus_time_error.png")}'
set title 'Mean error over {len(names)} real maps against time'
set xlabel 'median seconds per megatexel (this machine, 2 cores, PoCL)'
set ylabel 'mean NRMSE against the authored height'
set logscale x
set grid
unset key
plot '{dat}' using 1:2 with points pt 7 ps 1.5, '' using 1:2:3 with labels offset 1,0.6 left font ',10'
"""
subprocess.run(["gnuplot"], input=gp.encode(), check=False)
print(open(os.path.join(out, "corpus.md")).read())
