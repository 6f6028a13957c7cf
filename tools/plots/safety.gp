# The safety margin and the estimation error against time (§VI-D): V = ||x - x_sp||^2_P, which must stay
# below 1 (the safety set), and ||x - x_hat||^2_P, the estimation error that a rollback of ekf2 increases
# (the reason for T_est, §VI-C).
# Usage: gnuplot -e "dir='out/run'; runner='run'; title='...'" tools/plots/safety.gp
if (!exists("dir")) dir = 'out/run'
if (!exists("title")) title = 'run'
csv = dir.'/trace.csv'
set datafile separator ','
set key inside right top box opaque
set grid
set lmargin 12
set autoscale xfix
do for [fmt in 'png svg'] {
  if (fmt eq 'png') { set terminal pngcairo size 1400,900 font 'sans,11' } else { set terminal svg size 1400,900 font 'sans,11' }
  set output dir.'/safety.'.fmt
  set multiplot layout 2,1 title 'Safety and estimation error against time — '.title font 'sans,13' noenhanced
  set title 'V = ||x - x_{sp}||^2_P (true state; the safety set is V < 1)'
  set xlabel 'flight time t [s]'; set ylabel 'V'
  set yrange [0:1.2]
  plot csv using 1:35 with lines lw 1 lc rgb '#1f77b4' title 'V', \
       1 with lines lw 2 dt 2 lc rgb '#d62728' title 'boundary of the safety set'
  set yrange [0:*]
  set title 'Estimation error ||x - x_{hat}||^2_P (x_{hat}: the estimate of ekf2)'
  set ylabel '||x - x_{hat}||^2_P'
  plot csv using 1:36 with lines lw 1 lc rgb '#2ca02c' title 'estimation error'
  unset multiplot
}
