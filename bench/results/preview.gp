set terminal pngcairo size 1000,520 font 'DejaVu Sans,10'
set output 'bench/results/preview.png'
set title 'Preview update from one 5-MP frame: CPU ms, sampled (chromod) against full-frame demosaic + resize'
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set logscale y
set ylabel 'CPU ms per update (log)'
set grid ytics
set xtics rotate by -30
plot 'bench/results/preview.dat' using 2:xtic(1) title 'sampled (make\_preview)', '' using 3 title 'full frame'
