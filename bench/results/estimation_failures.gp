set terminal pngcairo size 1400,450
set output '/work/main/bench/results/estimation_failures.png'
set multiplot layout 1,3
set grid
set title 'error vs noise'
set xlabel 'noise scale (1 = camera model)'
set ylabel 'relit ΔE94'
plot '/work/main/bench/results/estimation_error_vs_noise.csv' u 1:2 w lp t 'fast 4D', '' u 1:3 w lp t '2D', '' u 1:4 w lp t 'exhaustive 4D', '' u 1:5 w l dt 2 t 'noise floor'
set title 'outside the gamut'
set xlabel 'blue channel excess'
set ylabel 'share flagged'
set y2tics
set y2label 'relit ΔE94 of unflagged pixels'
plot '/work/main/bench/results/estimation_error_vs_gamut.csv' u 1:2 w lp t 'fast: flagged', '' u 1:4 w lp t 'exhaustive: flagged', '' u 1:3 w lp axes x1y2 t 'fast: ΔE94 unflagged (right)'
set title 'Ch against Che'
set xlabel 'true Che'
set xtics 0.02
set ylabel '|Δlog10 Ch|'
set y2label '|ΔChe|'
plot '/work/main/bench/results/estimation_ch_vs_che.csv' u 1:2 w lp t 'Ch, noise-free', '' u 1:4 w lp t 'Ch, noisy', '' u 1:3 w lp axes x1y2 t 'Che, noise-free', '' u 1:5 w lp axes x1y2 t 'Che, noisy'
unset multiplot
