# Fig. 9 of the paper (§VI-C): the trajectory in 3-D: true position (plant, blue), the estimate (ekf2, green)
# and the setpoints of the tracking algorithm (red circles). Axes east, north, altitude (NED turned up).
# Usage: gnuplot -e "dir='out/run'; runner='run'; title='...'" tools/plots/fig9_3d.gp
if (!exists("dir")) dir = 'out/run'
if (!exists("title")) title = 'run'
csv = dir.'/trace.csv'
set datafile separator ','
set key top right box opaque
set grid
set view 60, 35
set view equal xy
set xyplane relative 0.05
set ticslevel 0
do for [fmt in 'png svg'] {
  if (fmt eq 'png') { set terminal pngcairo size 1200,1000 font 'sans,11' } else { set terminal svg size 1200,1000 font 'sans,11' }
  set output dir.'/fig9_3d.'.fmt
  set title 'Fig. 9: 3-D behaviour under CPS SR — '.title font 'sans,13' noenhanced
  set xlabel 'east [m]' offset 0,-1; set ylabel 'north [m]' offset 1,0; set zlabel 'altitude [m]' rotate by 90
  # A setpoint is drawn where it changes (the setpoint columns 26-28 hold it on every row).
  sp_prev = ''
  changed(n, e, d) = (key = sprintf('%.4f %.4f %.4f', n, e, d), c = (key ne sp_prev), sp_prev = key, c)
  splot csv using 3:2:(-$4) with lines lw 2 lc rgb '#1f77b4' title 'true (plant)', \
        ''  using 15:14:(-$16) with lines lw 1 lc rgb '#2ca02c' title 'estimate (ekf2)', \
        ''  using (changed($26, $27, $28) ? $27 : 1/0):26:(-$28) with points pt 6 ps 1.2 lw 2 lc rgb '#d62728' title 'setpoints'
}
