# Fig. 7 of the paper (§VI-B, "Control inputs updating time"): every interval between two consecutive control
# updates (actuator outputs routed to the plant) against time, the intervals in which a checkpoint (CP) or a
# rollback (RB) happened marked. Top: simulated time (what the plant sees: in lockstep the real duration of a
# checkpoint or rollback is charged to the plant's next step, so the mark is on the interval it lengthened);
# bottom (`rejuv run` only): real time between the same updates, the mark on the interval it happened in.
# A run without SR (or too short for one) has no CP or RB: the updates are drawn and the panel says so; a series
# with no point is left out (gnuplot refuses a log-scale plot whose series are all undefined).
# Usage: gnuplot -e "dir='out/run'; runner='run'; sr='on'; title='...'" tools/plots/fig7_control_intervals.gp
if (!exists("dir")) dir = 'out/run'
if (!exists("runner")) runner = 'run'
if (!exists("sr")) sr = 'on'
if (!exists("title")) title = 'run'
csv = dir.'/control.csv'
set datafile separator ','
set key outside right top box
set grid
is(m) = strcol(5) eq m
isw(m) = strcol(6) eq m
# An unmarked interval: neither CP nor RB (not `eq ''`: gnuplot 5.4 then finds no point when no row of the real-time
# column is marked, the empty last field of a line read as missing).
plain(c) = strcol(c) ne 'CP' && strcol(c) ne 'RB'
# An interval equal to the previous one (to 1 µs: in simulated time nearly all are the 4 ms period) is drawn
# once per 50 only: the same picture, an SVG of a few hundred kB instead of megabytes. CP and RB: every one.
prev = -1
fresh(v) = (d = abs(v - prev) > 0.001 || int(column(0)) % 50 == 0, prev = v, d)
stats csv using 3 nooutput
n = STATS_records
y_top = STATS_max * 1.3  # headroom: a run without SR has every interval at the period, not on the frame
# A 0 ms interval is a second update within one plant step; the plant applies the last one. In lockstep the
# restored chain publishes at once after every rollback, in the step of the last update before it; in real time a
# late update is followed by the regular one before the plant's next step. Drawn apart, and counted in the title.
zero(v) = v < 0.0005
stats csv using (zero($3) ? 1 : 0) nooutput
n_zero = int(STATS_sum)
stats csv using (is('CP') ? 1 : 0) nooutput
n_cp = int(STATS_sum)
stats csv using (is('RB') ? 1 : 0) nooutput
n_rb = int(STATS_sum)
stats csv using (isw('CP') ? 1 : 0) nooutput
n_cpw = int(STATS_sum)
stats csv using (isw('RB') ? 1 : 0) nooutput
n_rbw = int(STATS_sum)
no_marks = sr eq 'off' ? 'no SR in this run: no checkpoint (CP) or rollback (RB) to mark' : 'no checkpoint (CP) or rollback (RB) in this run'
# The optional series, as macros (empty when they have no point).
zero_s = n_zero > 0 ? ", '' using 1:(zero($3) ? $3 : 1/0) with points pt 2 ps 0.8 lc rgb '#7f7f7f' title '0 ms: second update in the same plant step'" : ""
cp_s = n_cp > 0 ? ", '' using 1:(is('CP') ? $3 : 1/0) with points pt 9 ps 1.2 lc rgb '#2ca02c' title 'checkpoint (CP) in the interval'" : ""
rb_s = n_rb > 0 ? ", '' using 1:(is('RB') ? $3 : 1/0) with points pt 11 ps 1.2 lc rgb '#d62728' title 'rollback (RB) in the interval'" : ""
cpw_s = n_cpw > 0 ? ", '' using 1:(isw('CP') ? $4 : 1/0) with points pt 9 ps 1.2 lc rgb '#2ca02c' title 'checkpoint (CP) in the interval'" : ""
rbw_s = n_rbw > 0 ? ", '' using 1:(isw('RB') ? $4 : 1/0) with points pt 11 ps 1.2 lc rgb '#d62728' title 'rollback (RB) in the interval'" : ""
do for [fmt in 'png svg'] {
  if (fmt eq 'png') { set terminal pngcairo size 1400,900 font 'sans,11' } else { set terminal svg size 1400,900 font 'sans,11' }
  set output dir.'/fig7_control_intervals.'.fmt
  set multiplot layout (runner eq 'run' ? 2 : 1),1 title 'Fig. 7: control inputs updating time — '.title font 'sans,13' noenhanced
  set title sprintf("Interval between consecutive control updates in simulated time: %d intervals (a checkpoint or rollback\nlengthens one by the time it is charged); %d of 0 ms: a second update within one plant step, the plant applies the last", n, n_zero) noenhanced
  set xlabel 'flight time t [s]'; set ylabel 'interval [ms]'
  set yrange [0:y_top]
  prev = -1
  if (n_cp + n_rb == 0) { set label 1 no_marks at graph 0.5, graph 0.92 center front noenhanced tc rgb '#d62728' } else { unset label 1 }
  plot csv using 1:(plain(5) && !zero($3) && fresh($3) ? $3 : 1/0) with points pt 7 ps 0.3 lc rgb '#1f77b4' title 'update' @zero_s @cp_s @rb_s
  if (runner eq 'run') {
    set title 'The same intervals in real time (wall clock of the kernel routing them)'
    set ylabel 'interval [ms]'
    set logscale y
    set yrange [*:*]
    # Real intervals all differ (scheduling jitter): in the SVG one normal update in 4 is drawn.
    if (n_cpw + n_rbw == 0) { set label 1 no_marks at graph 0.5, graph 0.92 center front noenhanced tc rgb '#d62728' } else { unset label 1 }
    plot csv every (fmt eq 'svg' ? 4 : 1) using 1:(plain(6) ? $4 : 1/0) with points pt 7 ps 0.3 lc rgb '#1f77b4' title 'update' @cpw_s @rbw_s
    unset logscale y
  }
  unset multiplot
  unset label 1
}
