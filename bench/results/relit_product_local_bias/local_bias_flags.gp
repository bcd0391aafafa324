set terminal pngcairo size 1000,600 font 'DejaVu Sans,10'
set output '/work/wt/flags37b/bench/results/relit_product_local_bias/local_bias_flags.png'
set title 'relit_product_bench: skin flagged (mean over folds x seeds) vs ink caught (worst fold x seed), per flag rule' noenhanced
set xlabel 'skin flagged, % (mean)'
set ylabel 'ink caught, % (worst run)'
set grid
set key outside right
set yrange [0:105]
set arrow from graph 0, first 95 to graph 1, first 95 nohead dt 2
plot '/work/wt/flags37b/bench/results/relit_product_local_bias/local_bias_flags.dat' index 0 using 1:2 with points pt 5 ps 2 title 'learned (off)', '' index 0 using 1:2:3 with labels offset 0,1 font ',8' notitle, '/work/wt/flags37b/bench/results/relit_product_local_bias/local_bias_flags.dat' index 1 using 1:2 with points pt 7 ps 2 title 'local bias, cap 4', '' index 1 using 1:2:3 with labels offset 0,1 font ',8' notitle, '/work/wt/flags37b/bench/results/relit_product_local_bias/local_bias_flags.dat' index 2 using 1:2 with points pt 9 ps 2 title 'local bias, cap 2', '' index 2 using 1:2:3 with labels offset 0,1 font ',8' notitle, '/work/wt/flags37b/bench/results/relit_product_local_bias/local_bias_flags.dat' index 3 using 1:2 with points pt 11 ps 2 title 'local bias, cap 1', '' index 3 using 1:2:3 with labels offset 0,1 font ',8' notitle
