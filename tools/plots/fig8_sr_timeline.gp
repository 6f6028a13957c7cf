# Fig. 8 of the paper (§V-C, §VI-B: the rollback handler's log) as a timeline of the SR events a run recorded
# (events.csv, from the kernel or the model; no --verbose needed): the mode (MC, RB, SC, update, CP) as a step
# line, and on their own rows each handler run (the model's; the runtime's handler shows as its SC request
# after each rollback), each arm of the rejuvenation timer (one per epoch), any refused second arm (docs/design.md §7:
# the recursive do_timer of §V-C), the restricted limits, checkpoints and rollbacks. Top: the whole run (the
# runtime's SR cycles during the plant's pre-flight alignment at negative times); bottom: the first SR cycles
# after the first rollback, labelled by epoch.
# A run without SR events (--no-sr) has one panel: the mode of every trace row (MC throughout) over the flight,
# and the figure says there was no SR.
# Usage: gnuplot -e "dir='out/run'; runner='run'; sr='on'; title='...'" tools/plots/fig8_sr_timeline.gp
if (!exists("dir")) dir = 'out/run'
if (!exists("sr")) sr = 'on'
if (!exists("title")) title = 'run'
csv = dir.'/events.csv'
set datafile separator ','
set grid xtics
set key outside right top box opaque
k(s) = strcol(3) eq s
modey(m) = m eq 'MC' ? 0 : m eq 'RB' ? 1 : m eq 'SC' ? 2 : m eq 'UP' ? 3 : 4
set ytics ('mode MC' 0, 'mode RB' 1, 'mode SC' 2, 'mode update' 3, 'mode CP' 4, 'handler run (model)' 5.8, 'handler: SC request' 6.7, \
           'timer armed' 7.5, 'arm refused' 8.5, 'limits Ū' 9.5, 'checkpoint' 10.5, 'rollback' 11.5, 'cold restart' 12.5)
set yrange [-0.5:13]
# One pass over the events: the counts and the first rollback (stats alone leaves its variables undefined
# when a kind never occurs, e.g. no refused arm).
t_begin = 0; t_end = 0; t_rb = -999; rollbacks = 0; armed = 0; refused = 0; handler_runs = 0; events = 0
tally(kind, t) = (events = events + 1, t_end = t, t_begin = (t < t_begin ? t : t_begin), \
                  kind eq 'rollback' ? (rollbacks = rollbacks + 1, t_rb = (t_rb == -999 ? t : t_rb)) : 0, \
                  kind eq 'timer_armed' ? armed = armed + 1 : 0, \
                  kind eq 'timer_refused' ? refused = refused + 1 : 0, \
                  kind eq 'handler_run' ? handler_runs = handler_runs + 1 : 0, 0)
# (Skipped on a file of its header alone: gnuplot would warn of no valid data.)
if (int(system("wc -l < '".csv."'")) > 1) { stats csv using (tally(strcol(3), $1)) nooutput }
if (t_rb == -999) t_rb = 0
if (events == 0) {
  stats dir.'/trace.csv' using 1 nooutput
  t_begin = STATS_min; t_end = STATS_max
}
no_sr = sr eq 'off' ? 'no SR in this run: no SR events (mode MC throughout; no timer, checkpoint or rollback)' \
                    : 'no SR event in this run (too short for one SR cycle?)'
do for [fmt in 'png svg'] {
  if (fmt eq 'png') { set terminal pngcairo size 1500,1000 font 'sans,11' } else { set terminal svg size 1500,1000 font 'sans,11' }
  set output dir.'/fig8_sr_timeline.'.fmt
  set multiplot layout (events > 0 ? 2 : 1),1 title 'Fig. 8: the SR timeline (rollback handler, timer, modes) — '.title font 'sans,13' noenhanced
  if (events == 0) { set label 1 no_sr at graph 0.5, graph 0.5 center front noenhanced tc rgb '#d62728' font 'sans,13' }
  do for [zoom = 0:(events > 0 ? 1 : 0)] {
    if (zoom == 0) {
      set title sprintf('Whole run: %d rollbacks, %d timer arms, %d refused second arms%s', rollbacks, armed, refused, \
                        handler_runs > 0 ? sprintf(', %d handler runs', handler_runs) : '')
      set xrange [t_begin : t_end > t_begin ? t_end : t_begin + 1]
    } else {
      set title 'Zoom: the first SR cycles after the first rollback (labels: epoch)'
      set xrange [t_rb - 0.3 : t_rb + 8]
    }
    set xlabel 'flight time t [s]'.(t_begin < 0 ? ' (before 0: during the plant''s pre-flight alignment)' : '')
    if (zoom == 1) { unset key } else { set key outside right top box opaque }
    if (events == 0) {
      plot dir.'/trace.csv' using 1:(modey(strcol(30))) with steps lw 2 lc rgb '#7f7f7f' title 'mode (trace)'
    } else {
    plot csv using 1:(k('mode') ? modey(strcol(6)) : 1/0) with steps lw 2 lc rgb '#7f7f7f' title 'mode', \
         ''  using 1:(k('handler_run') ? 5.8 : 1/0) with points pt 5 ps 1.0 lc rgb '#9467bd' title 'handler run', \
         ''  using 1:(k('mode') && strcol(6) eq 'SC' && strcol(8) ne 'kernel' ? 6.7 : 1/0) with points pt 4 ps 1.0 lc rgb '#9467bd' title 'handler requests SC', \
         ''  using 1:(k('timer_armed') ? 7.5 : 1/0) with points pt 7 ps 1.0 lc rgb '#2ca02c' title 'timer armed (once per epoch)', \
         ''  using 1:(k('timer_refused') ? 8.5 : 1/0) with points pt 2 ps 2.0 lw 3 lc rgb '#d62728' title 'second arm refused', \
         ''  using 1:(k('limits_written') ? 9.5 : 1/0) with points pt 13 ps 1.0 lc rgb '#ff7f0e' title 'restricted limits written', \
         ''  using 1:(k('checkpoint') ? 10.5 : 1/0) with points pt 9 ps 1.3 lc rgb '#17becf' title 'checkpoint committed', \
         ''  using 1:(k('checkpoint_failed') ? 10.5 : 1/0) with points pt 2 ps 1.5 lc rgb '#d62728' title 'checkpoint abandoned', \
         ''  using 1:(k('rollback') ? 11.5 : 1/0) with points pt 11 ps 1.3 lc rgb '#d62728' title 'rollback', \
         ''  using 1:(k('cold_restart') ? 12.5 : 1/0) with points pt 3 ps 2 lc rgb '#000000' title 'cold restart', \
         ''  using 1:(zoom == 1 && k('rollback') ? 12.2 : 1/0):(sprintf('e%d', int($4))) with labels offset 0,0.6 font 'sans,9' notitle
    }
  }
  unset multiplot
  unset label 1
}
