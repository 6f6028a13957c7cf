# The figures of `rejuv sweep` (§VI-D Fig. 11; docs/sweep.md): one metric, one panel per runner (model
# `rejuv sim`, runtime `rejuv run`) side by side. Two swept parameters: the cells as a map, each labelled with
# its value, and the level-1 contour (for max V the boundary of the safety set) interpolated between them.
# One parameter: max and mean over the seeds against it, and the level 1. An axis of names (an enum, e.g. the
# attack kind) is drawn as categories: no line joins them, no level is interpolated across them; a cell at or
# beyond the level is framed instead. A cell whose missions ended before the plan's attacks is marked *.
# rejuv sweep writes DIR/plot/figXX.vars.gp with the variables below and calls: gnuplot VARS tools/plots/sweep.gp
#   dir (the .dat folder), out (file without extension), runners ("sim run"), col (3: max V, 4: max est. err),
#   dims (1 or 2), categorical (1 if an axis is of names), attacks (the plan's N), zmax, reached (1 if a cell
#   reaches level 1), title, subtitle, zlabel, level_title, xlabel, xtics_text ('' or a tics list), ylabel, ytics_text
# The .dat columns: x y max_V_max max_est_err_P_max max_V_mean max_est_err_P_mean short attacks_min.
set datafile missing 'NaN'
n = words(runners)
# One parameter of names: points only (a line between two kinds would claim values between them). Set before the
# loop: its body's @style is expanded when the loop is read.
style = categorical ? 'points' : 'linespoints'
# A diverging scale centred on the level 1 (for max V the boundary of the safety set): blues inside, reds beyond.
# zmax is at least 1.05 (rejuv sweep), so the centre is always inside the colour range.
set palette defined (0 '#313695', 0.5 '#74add1', 1 '#ffffbf', (zmax + 1) / 2 '#f46d43', zmax '#a50026')
do for [fmt in "png svg"] {
  if (fmt eq "png") {
    set terminal pngcairo size (n == 1 ? 900 : 700*n),640 font 'sans,10' noenhanced
  } else {
    set terminal svg size (n == 1 ? 900 : 700*n),640 font 'sans,10' noenhanced
  }
  set output out.'.'.fmt
  # Room below each panel for the x label and, under it, the key (neither on the other).
  set bmargin 8
  set multiplot layout 1,n title title."\n".subtitle noenhanced font 'sans,11'
  do for [i=1:n] {
    r = word(runners, i)
    f = dir.'/'.r.'.dat'
    set title ((r eq 'sim') ? 'model (rejuv sim)' : 'runtime (rejuv run)') noenhanced
    set xlabel xlabel noenhanced
    if (strlen(xtics_text) > 0) { eval('set xtics '.xtics_text) } else { set xtics autofreq }
    set key at graph 0.5, graph -0.14 center top vertical Left reverse noenhanced
    short_title = sprintf('* missions ended before %d attacks (fewest flown shown)', attacks)
    if (dims == 2 && categorical) {
      # Categories: each cell on its own, nothing between them.
      set ylabel ylabel noenhanced
      if (strlen(ytics_text) > 0) { eval('set ytics '.ytics_text) } else { set ytics autofreq }
      set cbrange [0:zmax]
      set cblabel zlabel noenhanced
      set autoscale xfix
      set autoscale yfix
      set offsets graph 0, graph 0, graph 0, graph 0
      plot f using 1:2:col with image notitle, \
           f using 1:(column(col) >= 1 ? $2 : NaN) with points pt 4 ps 7 lw 3 lc rgb 'black' notitle, \
           NaN with points pt 4 ps 1.5 lw 3 lc rgb 'black' \
               title level_title.(reached ? '' : ' (not reached)').': its cells framed, nothing interpolated between categories', \
           f using 1:2:(column(7) > 0 ? sprintf("%.3f *\n%d attacks", column(col), column(8)) : sprintf('%.3f', column(col))) \
               with labels font 'sans,9' notitle, \
           NaN with points pt 0 lc rgb 'white' title short_title
    } else { if (dims == 2) {
      set contour base
      set cntrparam linear
      unset surface
      set cntrparam levels discrete 1.0
      set table $C
      splot f using 1:2:col
      unset table
      set cntrparam levels incremental 0.1, 0.1, 0.9
      set table $L
      splot f using 1:2:col
      unset table
      # Each level's line once more on its own, to label it at its second point (the first lies on the border).
      do for [k=1:9] {
        set cntrparam levels discrete k / 10.0
        set table sprintf('%s/%s.level%d.tab', dir, r, k)
        splot f using 1:2:col
        unset table
      }
      unset contour
      set surface
      set ylabel ylabel noenhanced
      if (strlen(ytics_text) > 0) { eval('set ytics '.ytics_text) } else { set ytics autofreq }
      set cbrange [0:zmax]
      set cblabel zlabel noenhanced
      set autoscale xfix
      set autoscale yfix
      set offsets graph 0, graph 0, graph 0, graph 0
      plot f using 1:2:col with image notitle, \
           $L using 1:2 with lines lw 1 dt 2 lc rgb '#555555' notitle, \
           $C using 1:2 with lines lw 3 lc rgb 'black' notitle, \
           NaN with lines lw 1 dt 2 lc rgb '#555555' title 'levels 0.1, 0.2, ... (interpolated)', \
           NaN with lines lw 3 lc rgb 'black' title (reached ? level_title : level_title.' (not reached)'), \
           f using 1:2:(column(7) > 0 ? sprintf("%.3f *\n%d attacks", column(col), column(8)) : sprintf('%.3f', column(col))) \
               with labels font 'sans,9' notitle, \
           NaN with points pt 0 lc rgb 'white' title short_title, \
           for [k=1:9] sprintf('%s/%s.level%d.tab', dir, r, k) every ::1::1 using 1:2:(sprintf('%.1f', k / 10.0)) \
               with labels font 'sans,8' tc rgb '#333333' notitle
    } else {
      set ylabel zlabel noenhanced
      set yrange [0:zmax]
      if (categorical) { set offsets 0.5, 0.5, 0, 0 } else { set offsets graph 0.05, graph 0.05, 0, 0 }
      set grid
      plot f using 1:col with @style pt 7 ps 1.5 lw 2 title 'max over seeds', \
           f using 1:(column(col + 2)) with @style pt 6 ps 1.5 dt 3 title 'mean over seeds', \
           f using 1:(column(7) > 0 ? column(col) : NaN) with points pt 8 ps 3 lw 2 lc rgb 'black' title short_title, \
           1 with lines dt 2 lw 2 lc rgb 'red' title level_title
      unset grid
      set autoscale y
    } }
  }
  unset multiplot
}
