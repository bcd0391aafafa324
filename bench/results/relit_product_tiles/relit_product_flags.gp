set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/relit_product_tiles/relit_product_flags.png'
set title 'skin flagged vs ink/marker caught (the lower), local bias off -> on'
set xlabel 'real or model skin flagged, %'
set ylabel 'ink / marker caught (the lower), %'
set grid
set key outside right
plot 'bench/results/relit_product_tiles/relit_product_flags.dat' index 0 using 1:2 with linespoints lw 2 title 'method real denoise-on', 'bench/results/relit_product_tiles/relit_product_flags.dat' index 1 using 1:2 with linespoints lw 2 title 'method model denoise-on', 'bench/results/relit_product_tiles/relit_product_flags.dat' index 2 using 1:2 with linespoints lw 2 title 'six-leds real denoise-on', 'bench/results/relit_product_tiles/relit_product_flags.dat' index 3 using 1:2 with linespoints lw 2 title 'six-leds model denoise-on'
