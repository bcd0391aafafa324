set terminal pngcairo size 900,500 font 'DejaVu Sans,10'
set output 'bench/results/relit_product_tiles/relit_product.png'
set title 'relit dE94 (mean of D65, A) through the product: model vs model + discrepancy'
set ylabel 'relit dE94, unflagged patch-interior pixels'
set style fill solid 0.8 border -1
set boxwidth 0.6
set grid ytics
set xtics rotate by -20
set yrange [0:*]
plot 'bench/results/relit_product_tiles/relit_product.dat' using 0:2:xtic(1) with boxes notitle lc rgb '#4477aa', '' using 0:2:(sprintf('%.3g', $2)) with labels offset 0,1 notitle
