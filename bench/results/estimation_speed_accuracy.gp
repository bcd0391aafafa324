set terminal pngcairo noenhanced size 900,600
set output '/work/wt/estim-fast/bench/results/estimation_speed_accuracy.png'
set title 'Inverters on 49152-pixel synthetic frames and the virtual-lab scene (scene:), 2 threads (circles noise-free, squares noisy; grey open: baseline run)'
set xlabel 'pixels per second'
set ylabel 'mean relit ΔE94 (six LEDs + D65)'
set logscale xy
set grid
set key outside right
plot '/work/wt/estim-fast/bench/results/estimation_speed_accuracy.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $5 : 1/0):1 with labels point pt 7 offset 1,0.5 notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $5 : 1/0):1 with labels point pt 5 offset 1,-0.5 tc rgb 'red' notitle, '/work/wt/estim-fast/bench/results/estimation_speed_accuracy_baseline.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $5 : 1/0):1 with labels right point pt 6 offset -1,-0.8 tc rgb 'gray40' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $5 : 1/0):1 with labels right point pt 4 offset -1,0.8 tc rgb 'gray40' notitle
