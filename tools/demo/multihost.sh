#!/usr/bin/env bash
# ./rejuv demo multihost [--duration S]: the square of launch/quad_multihost on two hosts, each a network namespace
# of this machine (docs/multihost.md). Root only. What it does, in order:
#   1. namespaces rejuv_mh_{vehicle,companion,intruder}, each joined to one bridge (in rejuv_mh_hub) by a veth pair,
#      10.77.0.1, .2 and .3;
#   2. a keystore in out/multihost/keys (`rejuv keys init`, `rejuv keys hosts` from the graph's policy);
#   3. an intruder in its namespace: a DDS participant without security that subscribes to the cross-host topic;
#   4. the two kernels: `rejuv run --host vehicle` (the plant, SR, the link closed in each secure interval) and
#      `rejuv run --host companion` (the monitor, fed through the links, and the planner, whose mission the
#      vehicle flies), on one DDS domain;
#   5. what happened: the vehicle's link closures against its mode changes, what the companion's monitor and the
#      intruder received, and whether the vehicle flew the companion planner's waypoint (its trace.csv).
# Everything it made (processes, namespaces, the bridge) is removed at its end, on failure and on Ctrl-C.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${REJUV_BUILD:-$root/build/default}"
bin="${REJUV_BIN:-$build/tools/rejuv/rejuv}"
peer="$build/tests/across_hosts/rejuv_dds_peer"
graph="$root/launch/quad_multihost.launch.pbtxt"
out="$root/out/multihost"
domain=77
duration=30

say() { printf '\033[1m[rejuv]\033[0m %s\n' "$*" >&2; }
usage() { say "usage: ./rejuv demo multihost [--duration S]   (root: it makes network namespaces)"; exit 2; }
while (($#)); do
  case "$1" in
    --duration) [[ $# -ge 2 && "$2" =~ ^[0-9]+$ && "$2" -gt 0 ]] || usage; duration="$2"; shift 2 ;;
    *) usage ;;
  esac
done
[[ $(id -u) -eq 0 ]] || { say "demo multihost needs root: it makes network namespaces, a bridge and nftables tables"; exit 2; }
for tool in ip nft; do command -v "$tool" >/dev/null || { say "demo multihost needs '$tool' (./rejuv installs it)"; exit 2; }; done
[[ -x "$peer" ]] || { say "demo multihost needs $peer (./rejuv build)"; exit 2; }

hub=rejuv_mh_hub
hosts=(vehicle companion intruder)
if ip netns list | grep -qE '^rejuv_mh_'; then
  say "namespaces rejuv_mh_* exist already: another demo multihost is running, or one was killed (remove them:"
  say "  for n in \$(ip netns list | grep -o '^rejuv_mh_[a-z]*'); do ip netns delete \$n; done)"
  exit 2
fi

pids=()
made=0
teardown() {
  local rc=$?
  trap - EXIT INT TERM
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  if ((made)); then
    for h in "${hosts[@]}"; do ip netns delete "rejuv_mh_$h" 2>/dev/null || true; done
    ip netns delete "$hub" 2>/dev/null || true  # the bridge and the hub's veth ends go with it
    say "removed the namespaces, the bridge and the veth pairs"
  fi
  exit "$rc"
}
trap teardown EXIT
trap 'say "interrupted"; exit 130' INT TERM

rm -rf "$out"
mkdir -p "$out"

say "demo multihost 1/5: three hosts as network namespaces on one bridge"
made=1
ip netns add "$hub"
ip -n "$hub" link add br0 type bridge
ip -n "$hub" link set br0 up
for i in "${!hosts[@]}"; do
  h="${hosts[$i]}"
  ns="rejuv_mh_$h"
  ip netns add "$ns"
  ip link add "rjmh_$h" type veth peer name "rjmhb_$h"
  ip link set "rjmh_$h" netns "$ns"
  ip link set "rjmhb_$h" netns "$hub"
  ip -n "$hub" link set "rjmhb_$h" master br0 up
  ip -n "$ns" addr add "10.77.0.$((i + 1))/24" dev "rjmh_$h"
  ip -n "$ns" link set "rjmh_$h" up
  ip -n "$ns" link set lo up
  say "         $ns: 10.77.0.$((i + 1)) on rjmh_$h"
done

say "demo multihost 2/5: the keystore (one CA; an identity and permissions per host, from the policy)"
"$bin" keys init "$out/keys"
"$bin" keys hosts "$out/keys" --launch "$graph" --domain "$domain"

say "demo multihost 3/5: an intruder on the bridge (10.77.0.3): a DDS participant without security reading"
say "         rejuv/vehicle_state"
cat >"$out/intruder.xml" <<XML
<CycloneDDS xmlns="https://cdds.io/config"><Domain id="any"><General><Interfaces><NetworkInterface address="10.77.0.3"/>
</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>
<Peers><Peer address="10.77.0.1"/><Peer address="10.77.0.2"/></Peers></Discovery></Domain></CycloneDDS>
XML
ip netns exec rejuv_mh_intruder "$peer" subscribe rejuv/vehicle_state --domain "$domain" --config "$out/intruder.xml" \
  --seconds "$((duration + 60))" >"$out/intruder.log" 2>&1 &
intruder=$!
pids+=("$intruder")

say "demo multihost 4/5: the two kernels, each its host's part of the graph (rejuv run --host), ${duration} s of flight"
"$bin" run "$graph" --host companion --keys "$out/keys" --domain "$domain" --net-port 0 >"$out/companion.log" 2>&1 &
companion=$!
pids+=("$companion")
# In the background and waited for, so that a signal to this script alone (not only Ctrl-C, which reaches every
# process of the terminal's group) runs the tear-down at once: bash defers a trap until a foreground child ends.
"$bin" run "$graph" --host vehicle --keys "$out/keys" --domain "$domain" --net-port 0 --duration "$duration" \
  --out "$out/vehicle" --no-figures >"$out/vehicle.log" 2>&1 &
vehicle=$!
pids+=("$vehicle")
vehicle_rc=0
wait "$vehicle" || vehicle_rc=$?
kill -INT "$companion" 2>/dev/null || true
wait "$companion" 2>/dev/null || true
kill -TERM "$intruder" 2>/dev/null || true  # it prints what it received as it ends
wait "$intruder" 2>/dev/null || true

say "demo multihost 5/5: what happened"
closes=$(grep -c 'link vehicle closed at' "$out/vehicle.log" || true)
opens=$(grep -c 'link vehicle opened at' "$out/vehicle.log" || true)
rollbacks=$(grep -c ',mode,[0-9]*,[0-9]*,RB,' "$out/vehicle/events.csv" 2>/dev/null || true)
say "  vehicle: rejuv run exited $vehicle_rc; its link closed $closes times and opened $opens times"
# The safety margin under the graph's attack (the run's summary line: "max V = 0.0942 (safe)"; V < 1: inside the set).
safety=$(grep -oE 'max V = [0-9.]+ \([a-z ]+\)' "$out/vehicle.log" | tail -1 || true)
attack=$(grep -oE 'attack=[A-Z_]+' "$out/vehicle.log" | head -1 || true)
say "           ${safety:-max V: not in out/multihost/vehicle.log}, ${attack:-attack: none}"
say "           ($rollbacks rollbacks in out/multihost/vehicle/events.csv); the first ones:"
grep 'link vehicle' "$out/vehicle.log" | head -6 >&2 || true
say "  companion: what its monitor received through the links (the last line):"
grep 'vehicle states received' "$out/companion.log" | tail -1 >&2 || say "           (no line: see out/multihost/companion.log)"
# The planner's mission: its one waypoint (-0.5, -0.5, -3 m NED, off the graph's square) as commander accepted it
# and gen_set_point flew it, and how close the vehicle's true position (trace.csv n_m, e_m, d_m) came to it.
say "  companion: its planner's mission (one waypoint at N -0.5 E -0.5 D -3 m, not on the graph's square):"
say "           $(grep -o 'planner: wrote [0-9]* mission uploads' "$out/companion.log" | tail -1 || echo 'no planner line')"
accepted=$(grep -c 'mission upload of 1 waypoints accepted' "$out/vehicle.log" || true)
flying=$(grep -c 'flying the uploaded mission' "$out/vehicle.log" || true)
closest=$(awk -F, 'NR > 1 { d = sqrt(($2 + 0.5)^2 + ($3 + 0.5)^2 + ($4 + 3)^2); if (min == "" || d < min) min = d }
                   END { if (min == "") print "none"; else printf "%.3f", min }' "$out/vehicle/trace.csv" 2>/dev/null || echo none)
say "  vehicle: commander logged $accepted of its uploads accepted; gen_set_point started flying one $flying time(s);"
say "           the vehicle's closest approach to the planner's waypoint: $closest m (out/multihost/vehicle/trace.csv)"
if [[ "$closest" != none ]] && awk -v d="$closest" 'BEGIN { exit !(d < 0.15) }'; then
  say "  the companion's waypoints were flown: the vehicle reached the planner's waypoint (within 0.15 m)"
else
  say "  the companion's waypoint was NOT reached in this flight (a longer --duration? see out/multihost/vehicle.log)"
fi
say "  intruder (no security): $(grep -o 'received [0-9]*' "$out/intruder.log" | tail -1 || echo 'nothing printed yet')"
say "logs: out/multihost/{vehicle,companion,intruder}.log; the vehicle's run: out/multihost/vehicle/"
exit "$vehicle_rc"
