set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/real_skin_relit.png'
set title 'where the relit error comes from: held-out real skin, model skin (noise alone), the 4D floor'
set xlabel 'camera noise (x four frames of a 40,000 e- sensor)'
set ylabel 'relit dE94, mean of D65 and A (unflagged skin)'
set grid
set key outside right
set logscale x 2
plot 'bench/results/real_skin_relit.dat' index 0 using 1:2 with linespoints lw 2 title 'method 4D full-spectrum fit (floor)', 'bench/results/real_skin_relit.dat' index 1 using 1:2 with linespoints lw 2 title 'method model learned', 'bench/results/real_skin_relit.dat' index 2 using 1:2 with linespoints lw 2 title 'method model prior x2', 'bench/results/real_skin_relit.dat' index 3 using 1:2 with linespoints lw 2 title 'method real learned', 'bench/results/real_skin_relit.dat' index 4 using 1:2 with linespoints lw 2 title 'method real prior x2', 'bench/results/real_skin_relit.dat' index 5 using 1:2 with linespoints lw 2 title 'six-leds 4D full-spectrum fit (floor)', 'bench/results/real_skin_relit.dat' index 6 using 1:2 with linespoints lw 2 title 'six-leds model learned', 'bench/results/real_skin_relit.dat' index 7 using 1:2 with linespoints lw 2 title 'six-leds model prior x2', 'bench/results/real_skin_relit.dat' index 8 using 1:2 with linespoints lw 2 title 'six-leds real learned', 'bench/results/real_skin_relit.dat' index 9 using 1:2 with linespoints lw 2 title 'six-leds real prior x2'
