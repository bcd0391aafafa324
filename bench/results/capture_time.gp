set terminal pngcairo size 1400,560 font 'DejaVu Sans,10'
set output 'bench/results/capture_time.png'
set multiplot layout 1,2 title 'Virtual lab, held-out seeds: mean and [min, max] against capture time'
set xlabel 'capture time, first step to last (s)'
set grid
set logscale x
set key top right
set title 'relit dE94 on every skin cell (six LEDs + D65)'
set ylabel 'relit dE94'
set yrange [0:*]
plot 'bench/results/capture_time_still.dat' using 1:2:3:4 with yerrorbars pt 7 title 'subject still', '' using 1:2:5 with labels offset 0,-1.2 font ',8' notitle, 'bench/results/capture_time_1x.dat' using 1:2:3:4 with yerrorbars pt 6 title 'subject moving, 1x the default drift and tremor', 'bench/results/capture_time_5x.dat' using 1:2:3:4 with yerrorbars pt 5 title 'subject moving, 5x the default drift and tremor'
set title 'skin flagged'
set ylabel 'skin cells flagged (%)'
set logscale y
set yrange [*:*]
plot 'bench/results/capture_time_still.dat' using 1:6:7:8 with yerrorbars pt 7 title 'subject still', '' using 1:6:5 with labels offset 0,-1.2 font ',8' notitle, 'bench/results/capture_time_1x.dat' using 1:6:7:8 with yerrorbars pt 6 title 'subject moving, 1x the default drift and tremor', 'bench/results/capture_time_5x.dat' using 1:6:7:8 with yerrorbars pt 5 title 'subject moving, 5x the default drift and tremor'
unset multiplot
