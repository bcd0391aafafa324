set terminal pngcairo size 900,600 font 'DejaVu Sans,10'
set output 'bench/results/plan_advisor/advisor_predicted_vs_mc.png'
set datafile separator ','
set grid
set key top left
set logscale xy
set title 'Plan advisor: predicted vs Monte Carlo mean relit {/Symbol D}E94 (plans × populations × seeds)'
set xlabel 'Monte Carlo fits (bounded least squares)'
set ylabel 'predicted (Fisher information)'
f(x)=x
plot [0.1:5] 'bench/results/plan_advisor/advisor.csv' every ::1 using 6:(strcol(2) eq 'skin' ? $5 : 1/0) with points pt 7 title 'skin box', 'bench/results/plan_advisor/advisor.csv' every ::1 using 6:(strcol(2) eq 'interior' ? $5 : 1/0) with points pt 6 ps 1.5 title 'interior box', f(x) with lines lc 'black' title 'equal', 1.25*x with lines dt 2 lc 'gray' title '±25%', 0.75*x with lines dt 2 lc 'gray' notitle
