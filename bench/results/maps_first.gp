# gnuplot bench/results/maps_first.gp (from the repository's root): issue 39 next part 1, derived data in the background, before/after side by side
set terminal pngcairo size 1000,500 font 'DejaVu Sans,10'
set output 'bench/results/maps_first.png'
set title "main job, two 5-MP cameras, side by side at load 8.7-12: seconds after the last frame"
set style data histogram
set style histogram cluster gap 1
set style fill solid 0.8 border -1
set ylabel 'wall seconds after the last frame'
set xlabel noenhanced 'before: derived data beside the maps at the same priority; after: derived data on threads at nice 19'
set grid ytics
set yrange [0:*]
set key top right
set xtics noenhanced font ',9'
plot 'bench/results/maps_first.dat' using 2:xtic(1) title 'maps, before', '' using 3 title 'maps, after', \
     '' using 4 title 'derived data done, before', '' using 5 title 'derived data done, after'
