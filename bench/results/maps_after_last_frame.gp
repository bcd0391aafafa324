# gnuplot bench/results/maps_after_last_frame.gp (from the repository's root): issue 39's tables from capture and cameras at once, before/after side by side
set terminal pngcairo size 1000,500 font 'DejaVu Sans,10'
set output 'bench/results/maps_after_last_frame.png'
set title "two 5-MP cameras, side by side at load 13-19: tables from capture (main job) and cameras at once (offline)"
set style data histogram
set style histogram cluster gap 1
set style fill solid 0.8 border -1
set ylabel 'wall seconds'
set xlabel noenhanced 'set-up: table + inverter set-up after the last frame, both cameras; offline estimate: chromo estimate SESSION_DIR, whole wall'
set grid ytics
set key top left
set xtics noenhanced font ',8'
plot 'bench/results/maps_after_last_frame.dat' using 2:xtic(1) title 'before', '' using 3 title 'after'
