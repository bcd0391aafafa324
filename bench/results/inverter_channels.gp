set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/inverter_channels.png'
set title 'the inverter alone: CPU us per skin cell (4D, one thread)'
set xlabel 'channels'
set ylabel 'us per cell'
set grid
set key outside right
plot 'bench/results/inverter_channels.dat' index 0 using 1:2 with linespoints lw 2 title 'fast', 'bench/results/inverter_channels.dat' index 1 using 1:2 with linespoints lw 2 title 'subspace'
