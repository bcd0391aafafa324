set terminal pngcairo noenhanced size 1400,500
set output '/work/main/bench/results/fast_budget_whole_frame.png'
set multiplot layout 1,3 title 'Fast 4D inverter: budget against accuracy on the 5-MP lab session, speed over the whole frame, scored on its 1078067 skin cells (circles noise-free, squares noisy; dashed: the 0.2 µs target)'
set grid
set logscale x
set xlabel 'CPU µs per cell and core'
set arrow from 0.2, graph 0 to 0.2, graph 1 nohead dt 2
set ylabel 'relit ΔE94 under D65 minus exhaustive (target <= 0.1)'
set arrow 2 from graph 0, first 0.1 to graph 1, first 0.1 nohead dt 2
plot '/work/main/bench/results/fast_budget_whole_frame.csv' u 4:(stringcolumn(2) eq 'noise-free' ? $7 : 1/0):1 w labels point pt 7 offset 1,0.5 font ',8' notitle, '' u 4:(stringcolumn(2) eq 'noisy' ? $7 : 1/0):1 w labels point pt 5 offset 1,-0.5 font ',8' tc rgb 'red' notitle
unset arrow 2
set ylabel 'mean relit ΔE94 (six LEDs + D65)'
plot '/work/main/bench/results/fast_budget_whole_frame.csv' u 4:(stringcolumn(2) eq 'noise-free' ? $5 : 1/0):1 w labels point pt 7 offset 1,0.5 font ',8' notitle, '' u 4:(stringcolumn(2) eq 'noisy' ? $5 : 1/0):1 w labels point pt 5 offset 1,-0.5 font ',8' tc rgb 'red' notitle
set ylabel 'share of skin cells flagged'
plot '/work/main/bench/results/fast_budget_whole_frame.csv' u 4:(stringcolumn(2) eq 'noise-free' ? $8 : 1/0):1 w labels point pt 7 offset 1,0.5 font ',8' notitle, '' u 4:(stringcolumn(2) eq 'noisy' ? $8 : 1/0):1 w labels point pt 5 offset 1,-0.5 font ',8' tc rgb 'red' notitle
unset multiplot
