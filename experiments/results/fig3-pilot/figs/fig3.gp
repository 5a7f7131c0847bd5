# Written by experiments/scripts/study_figures.py; `gnuplot fig3.gp` in this folder redraws fig3.png.
set terminal pngcairo size 1600,1440 font 'Sans,10'
set output 'fig3.png'
set datafile separator ','
set multiplot layout 4,4
set key top left
# --- pilot A, dt 8 s (row 1 of 4)
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:0.8]
set grid ytics
set title "pilot A, 8 s: total winrate, mean ± std"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "A" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):5:6 with yerrorbars pt 7 lc rgb '#1f77b4' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot A, 8 s: IQM of pairing winrates, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "A" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):7:8:9 with yerrorbars pt 7 lc rgb '#2ca02c' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot A, 8 s: row beats column, same-seed mean"
unset grid
set xrange [-0.5:3.5]; set yrange [3.5:-0.5]
set ytics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3)
set cbrange [0.3:0.7]; set palette defined (0 '#b2182b', 0.5 'white', 1 '#2166ac')
plot 'fig3_matrix.csv' every ::1 using ((strcol(1) eq "A" && $2 == 8) ? $4 : 1/0):3:(0.5):(0.5):7 with boxxyerror fs solid border lc rgb 'gray' lc palette notitle, '' every ::1 using ((strcol(1) eq "A" && $2 == 8) ? $4 : 1/0):3:(sprintf('%.2f', $7)) with labels notitle
set ytics auto; unset cbrange
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:1.0]
set grid ytics
set title "pilot A, 8 s: against its own controls, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "A" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) - 0.1 : 1/0):10:11:12 with yerrorbars pt 7 lc rgb '#d62728' title 'vs its center line (@center)' noenhanced, '' every ::1 using ((strcol(1) eq "A" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) + 0.1 : 1/0):13:14:15 with yerrorbars pt 5 lc rgb '#9467bd' title 'vs its random goals (@random)' noenhanced, 0.5 with lines dt 2 lc rgb 'gray' notitle, 0.5 + 0.05 with lines dt 3 lc rgb 'gray' notitle
# --- pilot A, dt 20 s (row 2 of 4)
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:0.8]
set grid ytics
set title "pilot A, 20 s: total winrate, mean ± std"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "A" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):5:6 with yerrorbars pt 7 lc rgb '#1f77b4' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot A, 20 s: IQM of pairing winrates, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "A" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):7:8:9 with yerrorbars pt 7 lc rgb '#2ca02c' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot A, 20 s: row beats column, same-seed mean"
unset grid
set xrange [-0.5:3.5]; set yrange [3.5:-0.5]
set ytics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3)
set cbrange [0.3:0.7]; set palette defined (0 '#b2182b', 0.5 'white', 1 '#2166ac')
plot 'fig3_matrix.csv' every ::1 using ((strcol(1) eq "A" && $2 == 20) ? $4 : 1/0):3:(0.5):(0.5):7 with boxxyerror fs solid border lc rgb 'gray' lc palette notitle, '' every ::1 using ((strcol(1) eq "A" && $2 == 20) ? $4 : 1/0):3:(sprintf('%.2f', $7)) with labels notitle
set ytics auto; unset cbrange
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:1.0]
set grid ytics
set title "pilot A, 20 s: against its own controls, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "A" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) - 0.1 : 1/0):10:11:12 with yerrorbars pt 7 lc rgb '#d62728' title 'vs its center line (@center)' noenhanced, '' every ::1 using ((strcol(1) eq "A" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) + 0.1 : 1/0):13:14:15 with yerrorbars pt 5 lc rgb '#9467bd' title 'vs its random goals (@random)' noenhanced, 0.5 with lines dt 2 lc rgb 'gray' notitle, 0.5 + 0.05 with lines dt 3 lc rgb 'gray' notitle
# --- pilot B, dt 8 s (row 3 of 4)
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:0.8]
set grid ytics
set title "pilot B, 8 s: total winrate, mean ± std"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "B" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):5:6 with yerrorbars pt 7 lc rgb '#1f77b4' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot B, 8 s: IQM of pairing winrates, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "B" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):7:8:9 with yerrorbars pt 7 lc rgb '#2ca02c' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot B, 8 s: row beats column, same-seed mean"
unset grid
set xrange [-0.5:3.5]; set yrange [3.5:-0.5]
set ytics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3)
set cbrange [0.3:0.7]; set palette defined (0 '#b2182b', 0.5 'white', 1 '#2166ac')
plot 'fig3_matrix.csv' every ::1 using ((strcol(1) eq "B" && $2 == 8) ? $4 : 1/0):3:(0.5):(0.5):7 with boxxyerror fs solid border lc rgb 'gray' lc palette notitle, '' every ::1 using ((strcol(1) eq "B" && $2 == 8) ? $4 : 1/0):3:(sprintf('%.2f', $7)) with labels notitle
set ytics auto; unset cbrange
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:1.0]
set grid ytics
set title "pilot B, 8 s: against its own controls, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "B" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) - 0.1 : 1/0):10:11:12 with yerrorbars pt 7 lc rgb '#d62728' title 'vs its center line (@center)' noenhanced, '' every ::1 using ((strcol(1) eq "B" && $2 == 8) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) + 0.1 : 1/0):13:14:15 with yerrorbars pt 5 lc rgb '#9467bd' title 'vs its random goals (@random)' noenhanced, 0.5 with lines dt 2 lc rgb 'gray' notitle, 0.5 + 0.05 with lines dt 3 lc rgb 'gray' notitle
# --- pilot B, dt 20 s (row 4 of 4)
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:0.8]
set grid ytics
set title "pilot B, 20 s: total winrate, mean ± std"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "B" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):5:6 with yerrorbars pt 7 lc rgb '#1f77b4' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot B, 20 s: IQM of pairing winrates, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "B" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) : 1/0):7:8:9 with yerrorbars pt 7 lc rgb '#2ca02c' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle
set title "pilot B, 20 s: row beats column, same-seed mean"
unset grid
set xrange [-0.5:3.5]; set yrange [3.5:-0.5]
set ytics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3)
set cbrange [0.3:0.7]; set palette defined (0 '#b2182b', 0.5 'white', 1 '#2166ac')
plot 'fig3_matrix.csv' every ::1 using ((strcol(1) eq "B" && $2 == 20) ? $4 : 1/0):3:(0.5):(0.5):7 with boxxyerror fs solid border lc rgb 'gray' lc palette notitle, '' every ::1 using ((strcol(1) eq "B" && $2 == 20) ? $4 : 1/0):3:(sprintf('%.2f', $7)) with labels notitle
set ytics auto; unset cbrange
set xtics ("es" 0, "es\\_d1" 1, "es\\_d2" 2, "es\\_d3" 3); set xrange [-0.6:3.6]
set yrange [0.3:1.0]
set grid ytics
set title "pilot B, 20 s: against its own controls, 95 % CI"
plot 'fig3_panels.csv' every ::1 using ((strcol(1) eq "B" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) - 0.1 : 1/0):10:11:12 with yerrorbars pt 7 lc rgb '#d62728' title 'vs its center line (@center)' noenhanced, '' every ::1 using ((strcol(1) eq "B" && $2 == 20) ? ((strcol(3) eq "es") ? 0 : (strcol(3) eq "es_d1") ? 1 : (strcol(3) eq "es_d2") ? 2 : 3) + 0.1 : 1/0):13:14:15 with yerrorbars pt 5 lc rgb '#9467bd' title 'vs its random goals (@random)' noenhanced, 0.5 with lines dt 2 lc rgb 'gray' notitle, 0.5 + 0.05 with lines dt 3 lc rgb 'gray' notitle
unset multiplot
