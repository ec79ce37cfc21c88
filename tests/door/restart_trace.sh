#!/usr/bin/env bash
# The trace records restarts (issue 18): the door system with a restart policy, VisualServoing killed by SIGSEGV
# mid-approach in simulated time (tests/scenarios/door_crash_restart.lua), run with `--trace FILE`; the policy's
# transition lines are in the trace at the tick its loss was found (T lines carry their event's time): the
# group's "one_for_one after visualserv killed by SIGSEGV ...: restarting visualserv" and the leaf's
# "restarted 1/1 in 5 s", at the same tick, before the root's DONE.
#   tests/door/restart_trace.sh DCA_EXE
set -uo pipefail
dca="$1"
src="${DCA_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
if ! "$dca" scenario --backend real --trace "$dir/run.trace" "$src/tests/scenarios/door_crash_restart.lua" \
    >"$dir/run.log" 2>&1; then
  echo "FAIL: the scenario failed:"; cat "$dir/run.log"; exit 1
fi
group="$(grep -E '^[0-9]+ T main\.dooropensyst: one_for_one after visualserv killed by SIGSEGV on host vision: restarting visualserv \(1/1 in 5 s\)$' "$dir/run.trace")" ||
  { echo "FAIL: no restart line of the group in the trace:"; grep ' T ' "$dir/run.trace" | tail -20; exit 1; }
leaf="$(grep -E '^[0-9]+ T main\.dooropensyst\.visualserv: restarted 1/1 in 5 s' "$dir/run.trace")" ||
  { echo "FAIL: no 'restarted 1/1 in 5 s' line of visualserv in the trace:"; grep ' T ' "$dir/run.trace" | tail -20; exit 1; }
t1="${group%% *}" t2="${leaf%% *}"
[ "$t1" = "$t2" ] || { echo "FAIL: the restart's lines at different ticks: $t1, $t2"; exit 1; }
echo "$group"
echo "$leaf"
echo "PASS: the restart is in the trace at tick $t1 ns"
