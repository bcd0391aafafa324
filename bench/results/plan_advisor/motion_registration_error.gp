set terminal pngcairo size 900,600 font 'DejaVu Sans,10'
set output 'bench/results/plan_advisor/motion_registration_error.png'
set datafile separator ','
set grid
set key top left
set title 'Subject motion: registration error vs time since the reference capture'
set xlabel 'time since the reference (D65) subject capture (s)'
set ylabel 'registration error (measurement px)'
plot 'bench/results/plan_advisor/motion.csv' every ::1 using 4:6 with points pt 7 ps 1.5 title 'largest over the image', 'bench/results/plan_advisor/motion.csv' every ::1 using 4:7 with points pt 6 ps 1.5 title 'RMS over the image'
