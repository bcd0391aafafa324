# gnuplot bench/results/white_target_unfitted.gp (from the repository's root): issue 39 next part 2, the white target not fitted, before/after side by side
set terminal pngcairo size 1000,500 font 'DejaVu Sans,10'
set output 'bench/results/white_target_unfitted.png'
set title "main job, two 5-MP cameras, side by side at load 9-12.5: the white target marked before the fit"
set style data histogram
set style histogram cluster gap 1
set style fill solid 0.8 border -1
set ylabel 'wall seconds'
set xlabel noenhanced 'maps: after the last frame; estimate: the per-pixel estimate of each camera (both at once)'
set grid ytics
set yrange [0:*]
set key top right
set xtics noenhanced font ',9'
plot 'bench/results/white_target_unfitted.dat' using 2:xtic(1) title 'maps, before', '' using 3 title 'maps, after', \
     '' using 4 title 'estimate cam0, before', '' using 5 title 'estimate cam0, after', \
     '' using 6 title 'estimate cam1, before', '' using 7 title 'estimate cam1, after'
