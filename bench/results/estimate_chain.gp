set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output '/work/wt/speed/bench/results/estimate_chain.png'
set title 'the chain per stage at 5.0 MP (wall s, 2 threads, mean over seeds)'
set ylabel 'wall seconds'
set style fill solid 0.8 border -1
set boxwidth 0.6
set grid ytics
set xtics rotate by -20
set yrange [0:*]
plot '/work/wt/speed/bench/results/estimate_chain.dat' using 0:2:xtic(1) with boxes notitle lc rgb '#4477aa', '' using 0:2:(sprintf('%.3g', $2)) with labels offset 0,1 notitle
