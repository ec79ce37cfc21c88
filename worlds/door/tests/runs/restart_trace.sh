#!/usr/bin/env bash
# The trace records restarts: the door system with a restart policy, VisualServoing killed by SIGSEGV
# mid-approach in simulated time (worlds/door/tests/scenarios/door_crash_restart.lua), run with `--trace FILE`; the policy's
# transition lines are in the trace at the tick its loss was found (T lines carry their event's time): the
# group's "one_for_one after visualserv killed by SIGSEGV ...: restarting visualserv" and the leaf's
# "restarted 1/1 in 5 s", at the same tick, before the root's DONE. That tick is defined (ARCHITECTURE.md "Time",
# "A restart"): the kill comes while time is held at 2 s, so the master finds the node lost at VisualServoing's
# next tick, 2.010 s (its period is 10 ms), and the restart is part of that tick's barrier: the lost line and
# both restart lines at 2010000000 ns, no sample of it at that tick, and the new process's first sample (n=1)
# at the first multiple of its period after the restart, 2020000000 ns.
#   worlds/door/tests/runs/restart_trace.sh DCA_EXE
set -uo pipefail
dca="$1"
src="${DCA_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
if ! "$dca" scenario --backend real --trace "$dir/run.trace" "$src/worlds/door/tests/scenarios/door_crash_restart.lua" \
    >"$dir/run.log" 2>&1; then
  echo "FAIL: the scenario failed:"; cat "$dir/run.log"; exit 1
fi
group="$(grep -E '^[0-9]+ T main\.dooropensyst: one_for_one after visualserv killed by SIGSEGV on host vision: restarting visualserv \(1/1 in 5 s\)$' "$dir/run.trace")" ||
  { echo "FAIL: no restart line of the group in the trace:"; grep ' T ' "$dir/run.trace" | tail -20; exit 1; }
leaf="$(grep -E '^[0-9]+ T main\.dooropensyst\.visualserv: restarted 1/1 in 5 s' "$dir/run.trace")" ||
  { echo "FAIL: no 'restarted 1/1 in 5 s' line of visualserv in the trace:"; grep ' T ' "$dir/run.trace" | tail -20; exit 1; }
t1="${group%% *}" t2="${leaf%% *}"
[ "$t1" = "$t2" ] || { echo "FAIL: the restart's lines at different ticks: $t1, $t2"; exit 1; }
vs='main\.dooropensyst\.visualserv'
lost=2010000000 first=2020000000
[ "$t1" = "$lost" ] || { echo "FAIL: the restart at tick $t1, not at $lost (the tick after the kill at 2 s)"; exit 1; }
grep -qxE "$lost L $vs" "$dir/run.trace" ||
  { echo "FAIL: no lost line of visualserv at $lost:"; grep -E " L " "$dir/run.trace"; exit 1; }
# visualserv.Vel's lines from the held tick on: the old process's last at 2 s, none at the loss, then n=1
vel="$(grep -E "^[0-9]+ D $vs\.Vel " "$dir/run.trace" | awk -v t=2000000000 '$1 >= t' | head -2 |
  awk 'NR == 1 { print $1 } NR == 2 { print $1, $4 }')"
want="2000000000
$first n=1"
[ "$vel" = "$want" ] ||
  { echo "FAIL: visualserv.Vel from the held tick on: got"; echo "$vel"; echo "expected"; echo "$want"; exit 1; }
echo "$group"
echo "$leaf"
echo "PASS: the restart is in the trace at tick $t1 ns, the new process's first sample at $first ns"
