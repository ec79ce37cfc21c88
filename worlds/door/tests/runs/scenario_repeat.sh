#!/usr/bin/env bash
# A scenario on simulated time run several times gives the same trace, byte for byte (ARCHITECTURE.md "Time"):
# each run writes its trace with `dca scenario --trace` (the world's lines and the transitions, cut at the
# root's outcome, as `dca run --trace`); with "loaded", once more while two busy loops burn both cores. Any
# difference fails and prints `dca trace diff` (the first divergence), with the traces kept for a re-run.
# With "placement", once more with every leaf of a host in one shared node (`--placement host`).
#   worlds/door/tests/runs/scenario_repeat.sh DCA_EXE SCENARIO.lua [RUNS] [loaded] [placement]
set -uo pipefail
dca="$1"; scenario="$2"; runs="${3:-2}"; loaded=""; placement=""
for opt in "${@:4}"; do
  case "$opt" in loaded) loaded=loaded ;; placement) placement=host ;; esac
done
dir="$(mktemp -d)"
name="$(basename "$scenario" .lua)"
burners=()
cleanup() { for p in "${burners[@]}"; do kill "$p" 2>/dev/null; done; }
trap cleanup EXIT

one() {  # one run: its name [dca scenario options...]
  local run="$1"; shift
  if ! "$dca" scenario --backend real "$@" --trace "$dir/$run.trace" "$scenario" >"$dir/$run.log" 2>&1; then
    echo "FAIL: $name, run $run (log $dir/$run.log):"; tail -30 "$dir/$run.log"; exit 1
  fi
  tail -1 "$dir/$run.log" | sed "s/^/  $run: /"
  [ "$run" = run1 ] && return
  if ! "$dca" trace diff "$dir/run1.trace" "$dir/$run.trace"; then
    echo "FAIL: $name: run $run differs from the first (traces kept in $dir)"; exit 1
  fi
}

for i in $(seq 1 "$runs"); do one "run$i"; done
if [ "$loaded" = loaded ]; then
  for _ in 1 2; do (while :; do :; done) & burners+=($!); done
  one loaded
  cleanup; burners=()
fi
[ -n "$placement" ] && one placement_host --placement host
echo "PASS: $name: $runs runs${loaded:+ and one loaded}${placement:+ and one with --placement host}, identical traces ($(wc -l <"$dir/run1.trace") lines)"
rm -rf "$dir"
