set terminal pngcairo size 900,600 font 'DejaVu Sans,10'
set output 'bench/results/plan_advisor/advisor_accuracy_vs_time.png'
set datafile separator ','
set grid
set logscale x
set key top right
set title 'Plan advisor: predicted relit {/Symbol D}E94 vs subject capture time (skin box, seed 1)'
set xlabel 'subject capture time (s)'
set ylabel 'mean relit {/Symbol D}E94'
plot 'bench/results/plan_advisor/advisor.csv' every ::1 using 4:((strcol(2) eq 'skin' && $3 == 1) ? $5 : 1/0) with points pt 7 ps 1.5 title 'predicted', 'bench/results/plan_advisor/advisor.csv' every ::1 using 4:((strcol(2) eq 'skin' && $3 == 1) ? $6 : 1/0) with points pt 6 ps 2 title 'Monte Carlo', 'bench/results/plan_advisor/advisor.csv' every ::1 using 4:((strcol(2) eq 'skin' && $3 == 1) ? $5 : 1/0):1 with labels noenhanced offset 0,1 notitle
