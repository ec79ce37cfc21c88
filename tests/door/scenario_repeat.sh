#!/usr/bin/env bash
# A scenario on simulated time run several times gives the same trace, byte for byte (ARCHITECTURE.md "Time"):
# each run writes the world's trace (DCA_SCENARIO_TRACE, the scenario passes it to the world), cut at the
# root's outcome (tests/support/door_scenario.lua end_trace); any difference
# fails and prints `dca trace diff` (the first divergence), with the traces kept for a re-run.
#   tests/door/scenario_repeat.sh DCA_EXE SCENARIO.lua [RUNS]
set -uo pipefail
dca="$1"; scenario="$2"; runs="${3:-2}"
dir="$(mktemp -d)"
name="$(basename "$scenario" .lua)"
for i in $(seq 1 "$runs"); do
  if ! DCA_SCENARIO_TRACE="$dir/run$i.trace" "$dca" scenario --backend real "$scenario" >"$dir/run$i.log" 2>&1; then
    echo "FAIL: $name, run $i (log $dir/run$i.log):"; tail -30 "$dir/run$i.log"; exit 1
  fi
  tail -1 "$dir/run$i.log" | sed "s/^/  run $i: /"
  # cut at the root's outcome (its tick, which the scenario wrote beside the trace), as `dca run --trace` does
  if [ -s "$dir/run$i.trace.end" ]; then
    awk -v e="$(cat "$dir/run$i.trace.end")" '($1 + 0) <= (e + 0)' "$dir/run$i.trace" >"$dir/run$i.cut" &&
      mv "$dir/run$i.cut" "$dir/run$i.trace"
  fi
  [ "$i" = 1 ] && continue
  if ! "$dca" trace diff "$dir/run1.trace" "$dir/run$i.trace"; then
    echo "FAIL: $name: run $i differs from the first (traces kept in $dir)"; exit 1
  fi
done
echo "PASS: $name: $runs runs, identical traces ($(wc -l <"$dir/run1.trace") lines)"
rm -rf "$dir"
