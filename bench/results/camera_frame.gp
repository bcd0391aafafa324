set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output '/work/wt-main5mp/bench/results/camera_frame.png'
set title 'Camera readout of one 2448x2048 frame'
set ylabel 'ms per frame (best of 5)'
set style fill solid 0.8 border -1
set boxwidth 0.6
set grid ytics
set xtics rotate by -20
set yrange [0:*]
set logscale y
set yrange [*:*]
plot '/work/wt-main5mp/bench/results/camera_frame.dat' using 0:2:xtic(1) with boxes notitle lc rgb '#4477aa', '' using 0:2:(sprintf('%.3g', $2)) with labels offset 0,1 notitle
