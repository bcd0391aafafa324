set terminal pngcairo size 1100,520 font 'DejaVu Sans,10'
set output 'bench/results/seed_study.png'
set title 'relit ΔE94 of held-out NIST skin, by capture plan (flat scene, noise x1.00, mean over folds x seeds)'
set ylabel 'relit ΔE94'
set xlabel 'relit under'
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.85 border -1
set boxwidth 0.9
set grid ytics
set key outside right
set yrange [0:*]
plot 'bench/results/seed_study.dat' using 2:xtic(1) title columnheader(2), '' using 3 title columnheader(3), '' using 4 title columnheader(4), '' using 5 title columnheader(5), '' using 6 title columnheader(6), '' using 7 title columnheader(7), '' using 8 title columnheader(8), '' using 9 title columnheader(9)
