# Written by f16race; run `gnuplot tournament.gp` in this folder to redraw.
set terminal pngcairo size 1800,550 font 'Sans,10'
set output 'tournament.png'
set datafile separator ','
set termoption noenhanced
set grid lc rgb '#dddddd'
set key outside right top
set multiplot layout 1,3 title 'Round-robin: 21312 races'
set title 'Total winrate (mean, std over runs)'
set xlabel ''
set ylabel 'winrate'
set yrange [0:1]
set style fill solid 0.6
set boxwidth 0.6
set xrange [-0.5:3.500000]
plot 'variants.csv' every ::1 using 1:2:3:xtic(7) with boxerrorbars lc rgb '#4477aa' notitle
unset arrow; unset label; unset object; set autoscale
set title 'IQM of pairing winrates, 95% CI'
set xlabel ''
set ylabel 'winrate'
set yrange [0:1]
set xrange [-0.5:3.500000]
plot 'variants.csv' every ::1 using 1:6:4:5:xtic(7) with yerrorbars pt 7 ps 1.5 lc rgb '#cc3311' notitle
unset arrow; unset label; unset object; set autoscale
set title 'Variant vs variant, mean pairing winrate (row vs column)'
set xlabel 'column variant'
set ylabel 'row variant'
set cbrange [0:1]
set palette defined (0 '#b2182b', 0.5 '#f7f7f7', 1 '#2166ac')
set grid noxtics noytics
set size square
set xrange [-0.5:3.500000]
set yrange [3.500000:-0.5]
set xtics ("es" 0, "es_d1" 1, "es_d2" 2, "es_d3" 3) rotate by 30 right
set ytics ("es" 0, "es_d1" 1, "es_d2" 2, "es_d3" 3)
set style fill solid 1.0 noborder
plot 'variant_matrix.csv' every ::1 using 1:2:(0.5):(0.5):3 with boxxyerror fc palette notitle, \
     'variant_matrix.csv' every ::1 using 1:2:4 with labels font 'Sans,9' notitle
unset arrow; unset label; unset object; set autoscale
unset multiplot
