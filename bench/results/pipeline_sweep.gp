set terminal pngcairo size 900,550 font 'DejaVu Sans,10'
set output '/work/wt-pipebench/bench/results/pipeline_sweep.png'
set title '5 MP Mono8 pattern cameras over loopback GigE Vision into storage: stored vs offered'
set xlabel 'offered, all cameras (MB/s; 1 Gb/s = 115 MB/s)'
set ylabel 'stored with acknowledgement (MB/s)'
set termoption noenhanced
set grid
set key top left
set xrange [0:*]
set yrange [0:*]
plot x title 'offered (zero loss)' lc rgb '#888888' dt 2, '/work/wt-pipebench/bench/results/pipeline_sweep.dat' index 0 using 1:2 with linespoints lw 2 pt 7 title 'default rmem_max, 1 camera', '/work/wt-pipebench/bench/results/pipeline_sweep.dat' index 1 using 1:2 with linespoints lw 2 pt 7 title 'default rmem_max, 2 cameras', '/work/wt-pipebench/bench/results/pipeline_sweep.dat' index 2 using 1:2 with linespoints lw 2 pt 7 title 'default rmem_max, 4 cameras', '/work/wt-pipebench/bench/results/pipeline_sweep.dat' index 3 using 1:2 with linespoints lw 2 pt 7 title 'raised rmem_max, 1 camera', '/work/wt-pipebench/bench/results/pipeline_sweep.dat' index 4 using 1:2 with linespoints lw 2 pt 7 title 'raised rmem_max, 2 cameras', '/work/wt-pipebench/bench/results/pipeline_sweep.dat' index 5 using 1:2 with linespoints lw 2 pt 7 title 'raised rmem_max, 4 cameras'
