set terminal pngcairo noenhanced size 1500,900
set output '/work/main/bench/results/estimation_speed_accuracy.png'
set multiplot layout 2,3 title 'Inverters on 49152-pixel synthetic frames and rendered virtual-lab sessions (lab:), 2 threads (circles noise-free, squares noisy)'
set xlabel 'pixels per second'
set logscale xy
set grid
set ylabel 'mean relit ΔE94 (six LEDs + D65)'
plot '/work/main/bench/results/estimation_speed_accuracy.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $5 : 1/0):1 with labels point pt 7 offset 1,0.5 notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $5 : 1/0):1 with labels point pt 5 offset 1,-0.5 tc rgb 'red' notitle
set ylabel 'relit ΔE94 under D65'
plot '/work/main/bench/results/estimation_speed_accuracy.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $6 : 1/0):1 with labels point pt 7 offset 1,0.5 font ',7' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $6 : 1/0):1 with labels point pt 5 offset 1,-0.5 font ',7' tc rgb 'red' notitle
set ylabel '|Δlog10 Cm|'
plot '/work/main/bench/results/estimation_speed_accuracy.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $7 : 1/0):1 with labels point pt 7 offset 1,0.5 font ',7' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $7 : 1/0):1 with labels point pt 5 offset 1,-0.5 font ',7' tc rgb 'red' notitle
set ylabel '|Δlog10 Ch|'
plot '/work/main/bench/results/estimation_speed_accuracy.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $8 : 1/0):1 with labels point pt 7 offset 1,0.5 font ',7' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $8 : 1/0):1 with labels point pt 5 offset 1,-0.5 font ',7' tc rgb 'red' notitle
set ylabel '|ΔβM|'
plot '/work/main/bench/results/estimation_speed_accuracy.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $9 : 1/0):1 with labels point pt 7 offset 1,0.5 font ',7' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $9 : 1/0):1 with labels point pt 5 offset 1,-0.5 font ',7' tc rgb 'red' notitle
set ylabel '|ΔChe|'
plot '/work/main/bench/results/estimation_speed_accuracy.csv' using 4:(stringcolumn(3) eq 'noise-free' ? $10 : 1/0):1 with labels point pt 7 offset 1,0.5 font ',7' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $10 : 1/0):1 with labels point pt 5 offset 1,-0.5 font ',7' tc rgb 'red' notitle
unset multiplot
