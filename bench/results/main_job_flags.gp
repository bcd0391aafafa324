# gnuplot bench/results/main_job_flags.gp (from the repository's root): the main job's specular and unexplained_colour flags per configuration
set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/main_job_flags.png'
set title "main job (two 5-MP cameras): highlights labelled specular or unexplained colour"
set style data histogram
set style histogram cluster gap 1
set style fill solid 0.8 border -1
set ylabel 'pixels'
set grid ytics
set key top right
set xtics noenhanced font ',9'
plot 'bench/results/main_job_flags.dat' using 2:xtic(1) title 'cam0 specular', '' using 3 title 'cam0 unexplained colour', \
     '' using 4 title 'cam1 specular', '' using 5 title 'cam1 unexplained colour'
