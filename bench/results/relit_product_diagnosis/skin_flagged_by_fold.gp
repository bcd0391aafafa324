# gnuplot skin_flagged_by_fold.gp: held-out real skin flagged per fold (mean of seeds 1, 2), six LEDs,
# relit_product_bench runs of this folder (skin_flagged_by_fold.dat, from summarise.py's rows).
set terminal pngcairo size 900,520
set output 'skin_flagged_by_fold.png'
set title "six LEDs, held-out real skin flagged per fold (mean of 2 seeds), product chain"
set ylabel "real skin flagged, %"
set xlabel "fold (fold 0 holds subject\\_006)"
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set key top left
set yrange [0:18]
plot 'skin_flagged_by_fold.dat' using 2:xtic(1) title 'default', '' using 3 title 'registration none', \
     '' using 4 title 'nested-CV scale q 0.9', '' using 5 title 'nested-CV scale q 0.99', 1 with lines dt 2 lc rgb 'black' title 'target 1%'
