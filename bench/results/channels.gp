set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/channels.png'
set title 'relit dE94 (6 LEDs + D65) on skin, fast/auto, mean over held-out seeds'
set ylabel 'mean dE94'
set style fill solid 0.8 border -1
set boxwidth 0.6
set grid ytics
set xtics rotate by -20
set yrange [0:*]
set logscale y
set yrange [*:*]
plot 'bench/results/channels.dat' using 0:2:xtic(1) with boxes notitle lc rgb '#4477aa', '' using 0:2:(sprintf('%.3g', $2)) with labels offset 0,1 notitle
