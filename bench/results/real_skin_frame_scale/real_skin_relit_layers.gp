set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/real_skin_frame_scale/real_skin_relit_layers.png'
set title 'relit layers on held-out real skin (targets: six LEDs 0.26, method 0.45)'
set xlabel 'camera noise (x four frames of a 40,000 e- sensor; 0 = noise-free)'
set ylabel 'relit dE94, mean of D65 and A (unflagged skin)'
set grid
set key outside right
plot 'bench/results/real_skin_frame_scale/real_skin_relit_layers.dat' index 0 using 1:2 with linespoints lw 2 title 'six-leds (learned): model', 'bench/results/real_skin_frame_scale/real_skin_relit_layers.dat' index 1 using 1:2 with linespoints lw 2 title 'six-leds (learned): model + discrepancy', 'bench/results/real_skin_frame_scale/real_skin_relit_layers.dat' index 2 using 1:2 with linespoints lw 2 title 'six-leds (learned): multi-pixel, model + discrepancy', 'bench/results/real_skin_frame_scale/real_skin_relit_layers.dat' index 3 using 1:2 with linespoints lw 2 title 'six-leds: 4D full-spectrum fit (floor)'
