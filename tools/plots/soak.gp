# The samples of `rejuv soak` (DIR/soak.csv) against SR cycles: the SR cycle's length, RSS of the kernel, the plant and each service,
# their open fds, their mappings, and the process counts (the kernel's threads and children, every process
# under it, each service's session: the live incarnation and its images). Flat lines are the pass criterion.
# Usage (rejuv soak calls it): gnuplot -e "csv='out/soak/soak.csv'; png='out/soak/soak.png'; nrss=11; nfds=11;
#        nmaps=11; ncols=50" tools/plots/soak.gp
if (!exists("csv")) csv = 'out/soak/soak.csv'
if (!exists("png")) png = 'out/soak/soak.png'
set datafile separator ','
set datafile missing 'NaN'
set terminal pngcairo size 2100,1100 font 'sans,10'
set output png
set multiplot layout 2,3 title 'rejuv soak: '.csv font 'sans,13' noenhanced
set key outside right top noenhanced font 'sans,8'
set grid
set xlabel 'SR cycles (rollbacks)'
c0 = 4; r0 = c0 + 1; f0 = r0 + nrss; m0 = f0 + nfds; p0 = m0 + nmaps

set title 'SR cycle [s simulated per rollback]'
set yrange [0:*]
plot csv using 1:c0 with linespoints pt 7 ps 0.3 title columnhead(c0)
set autoscale y

set title 'RSS [kB]'
set logscale y
plot for [i=r0:f0-1] csv using 1:i with linespoints pt 7 ps 0.3 title columnhead(i)
unset logscale y

set title 'open fds'
plot for [i=f0:m0-1] csv using 1:i with lines title columnhead(i)

set title 'mappings (/proc/<pid>/maps lines)'
plot for [i=m0:p0-1] csv using 1:i with lines title columnhead(i)

set title 'processes and threads'
plot for [i=p0:ncols] csv using 1:i with lines title columnhead(i)
unset multiplot
