# Fig. 10 of the paper (§VI-C): the position along x (north) and y (east) against time: true position (plant),
# the estimate (ekf2) and the setpoint.
# Usage: gnuplot -e "dir='out/run'; runner='run'; title='...'" tools/plots/fig10_xy_time.gp
if (!exists("dir")) dir = 'out/run'
if (!exists("title")) title = 'run'
csv = dir.'/trace.csv'
set datafile separator ','
set key inside right top box opaque
set grid
set autoscale xfix
do for [fmt in 'png svg'] {
  if (fmt eq 'png') { set terminal pngcairo size 1400,900 font 'sans,11' } else { set terminal svg size 1400,900 font 'sans,11' }
  set output dir.'/fig10_xy_time.'.fmt
  set multiplot layout 2,1 title 'Fig. 10: position along x and y against time — '.title font 'sans,13' noenhanced
  set title 'x (north)'
  set xlabel 'flight time t [s]'; set ylabel 'north [m]'
  plot csv using 1:2 with lines lw 2 lc rgb '#1f77b4' title 'true (plant)', \
       ''  using 1:14 with lines lw 1 lc rgb '#d62728' title 'estimate (ekf2)', \
       ''  using 1:26 with steps lw 2 lc rgb '#e6b800' title 'setpoint'
  set title 'y (east)'
  set xlabel 'flight time t [s]'; set ylabel 'east [m]'
  plot csv using 1:3 with lines lw 2 lc rgb '#1f77b4' title 'true (plant)', \
       ''  using 1:15 with lines lw 1 lc rgb '#d62728' title 'estimate (ekf2)', \
       ''  using 1:27 with steps lw 2 lc rgb '#e6b800' title 'setpoint'
  unset multiplot
}
