set terminal pngcairo size 1000,520 font 'DejaVu Sans,10'
set output 'bench/results/polarisation.png'
set multiplot layout 1,2 title 'Polarised sphere against the extinction ratio (mean over seeds; off / on: estimator without / with the films)'
set logscale x
set xrange [40:1250]
set xlabel 'extinction ratio 1:x at 550 nm'
set grid
set key bottom right
set ylabel '%'
set yrange [0:105]
plot 'bench/results/polarisation.dat' using 1:7 with linespoints title 'flagged at >= 4 sigma (on)', '' using 1:2 with linespoints dt 2 title 'flagged (off)', '' using 1:8 with linespoints title 'skin flagged (on)', 95 dt 2 title 'target 95%'
set yrange [0:*]
set ylabel 'ratio / %'
set key top right
plot 'bench/results/polarisation.dat' using 1:9 with linespoints title 'dE94 ratio highlight/skin, mean (on)', '' using 1:10 with linespoints title 'worst seed (on)', '' using 1:4 with linespoints dt 2 title 'worst seed (off)', '' using 1:11 with linespoints title '|surface bias| % (on)', '' using 1:6 with linespoints dt 2 title '|surface bias| % (off)', 1.2 dt 3 title 'ratio target 1.2', 5 dt 3 title 'bias target 5%'
unset multiplot
