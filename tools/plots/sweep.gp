# The figures of `rejuv sweep` (§VI-D Fig. 11; docs/sweep.md): one metric, one panel per runner (model
# `rejuv sim`, runtime `rejuv run`) side by side. Two swept parameters: the cells as a map, each labelled with
# its value, and the level-1 contour (for max V the boundary of the safety set) interpolated between them.
# One parameter: max and mean over the seeds against it, and the level 1.
# rejuv sweep writes DIR/plot/figXX.vars.gp with the variables below and calls: gnuplot VARS tools/plots/sweep.gp
#   dir (the .dat folder), out (file without extension), runners ("sim run"), col (3: max V, 4: max est. err),
#   dims (1 or 2), zmax, reached (1 if a cell reaches level 1), title, zlabel, level_title, xlabel, xtics_text ('' or a tics list), ylabel, ytics_text
set datafile missing 'NaN'
n = words(runners)
# A diverging scale centred on the level 1 (for max V the boundary of the safety set): blues inside, reds beyond.
# zmax is at least 1.05 (rejuv sweep), so the centre is always inside the colour range.
set palette defined (0 '#313695', 0.5 '#74add1', 1 '#ffffbf', (zmax + 1) / 2 '#f46d43', zmax '#a50026')
do for [fmt in "png svg"] {
  if (fmt eq "png") {
    set terminal pngcairo size (n == 1 ? 800 : 640*n),580 font 'sans,10' noenhanced
  } else {
    set terminal svg size (n == 1 ? 800 : 640*n),580 font 'sans,10' noenhanced
  }
  set output out.'.'.fmt
  set multiplot layout 1,n title title noenhanced font 'sans,12'
  do for [i=1:n] {
    r = word(runners, i)
    f = dir.'/'.r.'.dat'
    set title ((r eq 'sim') ? 'model (rejuv sim)' : 'runtime (rejuv run)') noenhanced
    set xlabel xlabel noenhanced
    if (strlen(xtics_text) > 0) { eval('set xtics '.xtics_text) } else { set xtics autofreq }
    set key below noenhanced
    if (dims == 2) {
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
           f using 1:2:(sprintf('%.3f', column(col))) with labels font 'sans,9' notitle, \
           for [k=1:9] sprintf('%s/%s.level%d.tab', dir, r, k) every ::1::1 using 1:2:(sprintf('%.1f', k / 10.0)) \
               with labels font 'sans,8' tc rgb '#333333' notitle
    } else {
      set ylabel zlabel noenhanced
      set yrange [0:zmax]
      set offsets graph 0.05, graph 0.05, 0, 0
      set grid
      plot f using 1:col with linespoints pt 7 lw 2 title 'max over seeds', \
           f using 1:(column(col + 2)) with linespoints pt 6 dt 3 title 'mean over seeds', \
           1 with lines dt 2 lw 2 lc rgb 'red' title level_title
      unset grid
      set autoscale y
    }
  }
  unset multiplot
}
