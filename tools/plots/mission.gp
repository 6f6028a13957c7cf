# The figures of a run's time series (the CSV of `rejuv sim` / `rejuv run`): the paper's Fig. 9 (top view:
# true position, estimate, setpoints), Fig. 10 (north and east against time) and the safety margin
# V = ||x - x_sp||^2_P against time, which must stay below 1.
# Usage: gnuplot -e "csv='out/timeseries.csv'; png='out/mission.png'; title='...'" tools/plots/mission.gp
if (!exists("csv")) csv = 'out/timeseries.csv'
if (!exists("png")) png = 'out/mission.png'
if (!exists("title")) title = 'quad_square'
set datafile separator ','
set terminal pngcairo size 1500,1000 font 'sans,11'
set output png
set multiplot layout 2,2 title title font 'sans,14' noenhanced
set key top left box opaque
set grid

set title 'Top view (Fig. 9): true position, estimate, setpoint'
set xlabel 'east [m]'; set ylabel 'north [m]'
set size ratio -1
plot csv every 20 using 3:2 with lines lw 2 lc rgb '#1f77b4' title 'true (plant)', \
     ''  every 20 using 15:14 with lines lw 1 lc rgb '#2ca02c' title 'estimate (ekf2)', \
     ''  every 200 using 27:26 with points pt 6 ps 0.8 lc rgb '#d62728' title 'setpoint'
set size noratio

set title 'North and east against time (Fig. 10)'
set xlabel 't [s]'; set ylabel 'position [m]'
plot csv every 20 using 1:2 with lines lw 2 lc rgb '#1f77b4' title 'north (true)', \
     ''  every 20 using 1:26 with lines lw 1 dt 2 lc rgb '#d62728' title 'north setpoint', \
     ''  every 20 using 1:3 with lines lw 2 lc rgb '#ff7f0e' title 'east (true)', \
     ''  every 20 using 1:27 with lines lw 1 dt 2 lc rgb '#9467bd' title 'east setpoint'

set title 'Safety: V = ||x - x_{sp}||^2_P (safe below 1)'
set xlabel 't [s]'; set ylabel 'V'
set yrange [0:1.2]
plot csv every 5 using 1:35 with lines lw 1 lc rgb '#1f77b4' title 'V', \
     1 with lines lw 2 dt 2 lc rgb '#d62728' title 'boundary of the safety set'
set yrange [*:*]

set title 'Altitude and collective thrust'
set xlabel 't [s]'; set ylabel 'altitude [m]'; set y2label 'F [N]'
set ytics nomirror; set y2tics
plot csv every 20 using 1:(-$4) with lines lw 2 lc rgb '#1f77b4' title 'altitude (true)', \
     ''  every 20 using 1:31 axes x1y2 with lines lw 1 lc rgb '#7f7f7f' title 'F'
unset multiplot
