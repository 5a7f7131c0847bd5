# Written by f16race; run `gnuplot pairings.gp` in this folder to redraw.
set terminal pngcairo size 3075,2840 font 'Sans,10'
set output 'pairings.png'
set datafile separator ','
set termoption noenhanced
set grid lc rgb '#dddddd'
set key outside right top
set multiplot layout 1,1 title 'Pairing winrate, every entry: 21312 races'
set title 'Winrate of the row entry against the column entry'
set xlabel 'column entry'
set ylabel 'row entry'
set cbrange [0:1]
set palette defined (0 '#b2182b', 0.5 '#f7f7f7', 1 '#2166ac')
set grid noxtics noytics
set size square
set xrange [-0.5:36.500000]
set yrange [36.500000:-0.5]
set xtics ("es_s1" 0, "es_d1_s1" 1, "es_d2_s1" 2, "es_d3_s1" 3, "es_s2" 4, "es_d1_s2" 5, "es_d2_s2" 6, "es_d3_s2" 7, "es_s3" 8, "es_d1_s3" 9, "es_d2_s3" 10, "es_d3_s3" 11, "untrained" 12, "es_s1@center" 13, "es_s1@random" 14, "es_d1_s1@center" 15, "es_d1_s1@random" 16, "es_d2_s1@center" 17, "es_d2_s1@random" 18, "es_d3_s1@center" 19, "es_d3_s1@random" 20, "es_s2@center" 21, "es_s2@random" 22, "es_d1_s2@center" 23, "es_d1_s2@random" 24, "es_d2_s2@center" 25, "es_d2_s2@random" 26, "es_d3_s2@center" 27, "es_d3_s2@random" 28, "es_s3@center" 29, "es_s3@random" 30, "es_d1_s3@center" 31, "es_d1_s3@random" 32, "es_d2_s3@center" 33, "es_d2_s3@random" 34, "es_d3_s3@center" 35, "es_d3_s3@random" 36) rotate by 30 right
set ytics ("es_s1" 0, "es_d1_s1" 1, "es_d2_s1" 2, "es_d3_s1" 3, "es_s2" 4, "es_d1_s2" 5, "es_d2_s2" 6, "es_d3_s2" 7, "es_s3" 8, "es_d1_s3" 9, "es_d2_s3" 10, "es_d3_s3" 11, "untrained" 12, "es_s1@center" 13, "es_s1@random" 14, "es_d1_s1@center" 15, "es_d1_s1@random" 16, "es_d2_s1@center" 17, "es_d2_s1@random" 18, "es_d3_s1@center" 19, "es_d3_s1@random" 20, "es_s2@center" 21, "es_s2@random" 22, "es_d1_s2@center" 23, "es_d1_s2@random" 24, "es_d2_s2@center" 25, "es_d2_s2@random" 26, "es_d3_s2@center" 27, "es_d3_s2@random" 28, "es_s3@center" 29, "es_s3@random" 30, "es_d1_s3@center" 31, "es_d1_s3@random" 32, "es_d2_s3@center" 33, "es_d2_s3@random" 34, "es_d3_s3@center" 35, "es_d3_s3@random" 36)
set style fill solid 1.0 noborder
plot 'heatmap.csv' every ::1 using 1:2:(0.5):(0.5):3 with boxxyerror fc palette notitle, \
     'heatmap.csv' every ::1 using 1:2:4 with labels font 'Sans,9' notitle
unset arrow; unset label; unset object; set autoscale
unset multiplot
