# Fig. 9 of the paper (§VI-C): the trajectory in 3-D: true position (plant, blue), the estimate (ekf2, green)
# and the setpoints of the tracking algorithm (red circles). Axes east, north, altitude (NED turned up).
# Usage: gnuplot -e "dir='out/run'; runner='run'; sr='on'; title='...'" tools/plots/fig9_3d.gp
if (!exists("dir")) dir = 'out/run'
if (!exists("sr")) sr = 'on'
if (!exists("title")) title = 'run'
csv = dir.'/trace.csv'
set datafile separator ','
set key top right box opaque
set grid
# East and north share one scale. Altitude varies far less than position in a mission (a few cm against metres): on
# the same scale it would be a flat line, so it is stretched by a stated whole factor (in the axis label) such that
# its extent is about half the horizontal one; 1 when it needs none.
stats csv using 3 name 'E' nooutput
stats csv using 2 name 'N' nooutput
stats csv using (-$4) name 'Z' nooutput
xy_extent = (E_max - E_min > N_max - N_min ? E_max - E_min : N_max - N_min)
z_extent = Z_max - Z_min
stretch = (z_extent > 0 && xy_extent > 2 * z_extent) ? floor(0.5 * xy_extent / z_extent) : 1
stretch = stretch > 1000 ? 1000 : stretch
set view 60, 35, 1.5, stretch
set view equal xyz
# Three or four altitude ticks however short the axis is drawn; east and north ticks kept off each other's corner.
z_step = (z_extent > 0 ? 10 ** floor(log10(z_extent)) : 1)
z_step = (z_extent / z_step > 4 ? 2 * z_step : z_step)
z_step = (z_extent / z_step > 4 ? 2.5 * z_step : z_step)
set ztics z_step
set xtics offset 0,-0.6
set ytics offset 1.5,0
set xyplane relative 0.05
set ticslevel 0
do for [fmt in 'png svg'] {
  if (fmt eq 'png') { set terminal pngcairo size 1200,1000 font 'sans,11' } else { set terminal svg size 1200,1000 font 'sans,11' }
  set output dir.'/fig9_3d.'.fmt
  set title (sr eq 'off' ? 'Fig. 9: 3-D behaviour, no SR in this run — ' : 'Fig. 9: 3-D behaviour under CPS SR — ').title font 'sans,13' noenhanced
  set xlabel 'east [m]' offset 0,-1; set ylabel 'north [m]' offset 4,0; set zlabel (stretch > 1 ? sprintf('altitude [m], drawn %g× taller than east/north', stretch) : 'altitude [m]') rotate by 90
  # A setpoint is drawn where it changes (the setpoint columns 26-28 hold it on every row).
  sp_prev = ''
  changed(n, e, d) = (key = sprintf('%.4f %.4f %.4f', n, e, d), c = (key ne sp_prev), sp_prev = key, c)
  splot csv using 3:2:(-$4) with lines lw 2 lc rgb '#1f77b4' title 'true (plant)', \
        ''  using 15:14:(-$16) with lines lw 1 lc rgb '#2ca02c' title 'estimate (ekf2)', \
        ''  using (changed($26, $27, $28) ? $27 : 1/0):26:(-$28) with points pt 6 ps 1.2 lw 2 lc rgb '#d62728' title 'setpoints'
}
