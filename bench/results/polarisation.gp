set terminal pngcairo size 1000,520 font 'DejaVu Sans,10'
set output 'bench/results/polarisation.png'
set multiplot layout 1,2 title 'Polarised sphere: optical highlights against the extinction ratio (mean over seeds)'
set logscale x
set xrange [40:1250]
set xlabel 'extinction ratio 1:x at 550 nm'
set grid
set key bottom right
set ylabel '%'
set yrange [0:105]
plot 'bench/results/polarisation.dat' using 1:2 with linespoints title 'flagged at >= 4 sigma', '' using 1:3 with linespoints title 'skin flagged', 95 dt 2 title 'target 95%'
set yrange [0:*]
set ylabel 'ratio / %'
set key top right
plot 'bench/results/polarisation.dat' using 1:4 with linespoints title 'dE94 ratio highlight/skin', '' using 1:5 with linespoints title '|surface bias| % (>= 10 sigma)', 1.2 dt 2 title 'ratio target 1.2', 5 dt 3 title 'bias target 5%'
unset multiplot
