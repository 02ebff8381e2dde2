# gnuplot /work/main/bench/results/correct_curves.gp  -> correct_curves.png
set terminal pngcairo size 1040,480 font ',10'
set output '/work/main/bench/results/correct_curves.png'
set datafile separator ','
set logscale y
set grid
set key top right font ',8' noenhanced
set xlabel 'seconds (in-process, warm; tolerances 0.001 .. 1e-05)'
set ylabel 'energy / lowest energy found - 1 (+1e-7)'
set multiplot layout 1,2 title 'relief --correct: energy against time (2-core PoCL)'
best = 1e300
stats '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'gk_castell_wall_v01' ? $5 : 1/0) nooutput
best = STATS_min
set title 'gk_castell_wall_v01' noenhanced
plot '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'gk_castell_wall_v01' && strcol(2) eq 'ternary (first version)' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 1 pt 4 title 'ternary (first version)', \
  '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'gk_castell_wall_v01' && strcol(2) eq 'golden with relax 1.5' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 2 pt 5 title 'golden with relax 1.5', \
  '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'gk_castell_wall_v01' && strcol(2) eq 'brent' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 3 pt 6 title 'brent', \
  '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'gk_castell_wall_v01' && strcol(2) eq 'brent with relax 1.5 (default)' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 4 pt 7 title 'brent with relax 1.5 (default)'
best = 1e300
stats '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'nx_brickfloor' ? $5 : 1/0) nooutput
best = STATS_min
set title 'nx_brickfloor' noenhanced
plot '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'nx_brickfloor' && strcol(2) eq 'ternary (first version)' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 1 pt 4 title 'ternary (first version)', \
  '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'nx_brickfloor' && strcol(2) eq 'golden with relax 1.5' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 2 pt 5 title 'golden with relax 1.5', \
  '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'nx_brickfloor' && strcol(2) eq 'brent' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 3 pt 6 title 'brent', \
  '/work/main/bench/results/correct_curves.csv' using (strcol(1) eq 'nx_brickfloor' && strcol(2) eq 'brent with relax 1.5 (default)' ? $4 : 1/0):($5 / best - 1 + 1e-7) with linespoints lc 4 pt 7 title 'brent with relax 1.5 (default)'
unset multiplot
