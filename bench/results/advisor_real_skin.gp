set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/advisor_real_skin.png'
set title 'plan advisor: predicted against measured σ Cm on held-out real skin (5 folds)'
set xlabel 'frames per capture'
set ylabel 'σ Cm (mean over folds)'
set grid
set key outside right
set logscale x 2
plot 'bench/results/advisor_real_skin.dat' index 0 using 1:2 with linespoints lw 2 title 'method predicted, camera noise alone', 'bench/results/advisor_real_skin.dat' index 1 using 1:2 with linespoints lw 2 title 'method predicted, with discrepancy', 'bench/results/advisor_real_skin.dat' index 2 using 1:2 with linespoints lw 2 title 'method measured on real skin', 'bench/results/advisor_real_skin.dat' index 3 using 1:2 with linespoints lw 2 title 'multispectral predicted, camera noise alone', 'bench/results/advisor_real_skin.dat' index 4 using 1:2 with linespoints lw 2 title 'multispectral predicted, with discrepancy', 'bench/results/advisor_real_skin.dat' index 5 using 1:2 with linespoints lw 2 title 'multispectral measured on real skin'
