set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/real_skin_frame_scale/real_skin.png'
set title 'real skin flagged (held-out NIST subjects, 5 folds)'
set xlabel 'camera noise (x four frames of a 40,000 e- sensor)'
set ylabel 'skin flagged (%)'
set grid
set key outside right
set logscale x 2
plot 'bench/results/real_skin_frame_scale/real_skin.dat' index 0 using 1:2 with linespoints lw 2 title 'six-leds frame-s', 'bench/results/real_skin_frame_scale/real_skin.dat' index 1 using 1:2 with linespoints lw 2 title 'six-leds learned', 'bench/results/real_skin_frame_scale/real_skin.dat' index 2 using 1:2 with linespoints lw 2 title 'six-leds subj-s'
