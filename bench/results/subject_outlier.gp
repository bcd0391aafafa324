set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/subject_outlier.png'
set title 'residual of the 4D full-spectrum fit: subjects far from their training set'
set xlabel 'wavelength (nm)'
set ylabel 'measured - fitted (albedo)'
set grid
set key outside right
plot 'bench/results/subject_outlier.dat' index 0 using 1:2 with linespoints lw 2 title 'subject 003 (held-out D2 48)', 'bench/results/subject_outlier.dat' index 1 using 1:2 with linespoints lw 2 title 'subject 006 (held-out D2 216)', 'bench/results/subject_outlier.dat' index 2 using 1:2 with linespoints lw 2 title 'subject 022 (held-out D2 46)', 'bench/results/subject_outlier.dat' index 3 using 1:2 with linespoints lw 2 title '+2 sd of the training residuals (fold 0)', 'bench/results/subject_outlier.dat' index 4 using 1:2 with linespoints lw 2 title '-2 sd (fold 0)'
