set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/inverter_speed.png'
set title 'relit dE94 (D65, A) of noisy skin against pixels/s, auto model; points: plans of 4-27 channels'
set xlabel 'pixels per second (2 threads)'
set ylabel 'relit dE94'
set grid
set key outside right
set logscale x 2
plot 'bench/results/inverter_speed.dat' index 0 using 1:2 with linespoints lw 2 title 'fast model', 'bench/results/inverter_speed.dat' index 1 using 1:2 with linespoints lw 2 title 'fast real', 'bench/results/inverter_speed.dat' index 2 using 1:2 with linespoints lw 2 title 'subspace model', 'bench/results/inverter_speed.dat' index 3 using 1:2 with linespoints lw 2 title 'subspace real'
