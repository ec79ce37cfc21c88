#!/usr/bin/env bash
# A failing scenario in simulated time says how to see its failure again, and that re-run reproduces it
# worlds/door/tests/runs/failing_scenario.lua fails on purpose; its output must name the seed, the trace file
# and the command (`seed N, trace FILE, rerun: dca scenario ...`); that command, run, fails in the same step
# with the same message, and its trace is the first run's byte for byte (`dca trace diff`).
#   worlds/door/tests/runs/scenario_rerun.sh DCA_EXE
set -uo pipefail
dca="$1"
src="${DCA_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
dir="$(mktemp -d)"
"$dca" scenario --backend real "$src/worlds/door/tests/runs/failing_scenario.lua" >"$dir/first.log" 2>&1
code=$?
[ "$code" = 1 ] || { echo "FAIL: the scenario should fail (exit 1), got $code:"; cat "$dir/first.log"; exit 1; }
line="$(grep -E '^  seed [0-9]+, trace [^,]+, rerun: dca scenario ' "$dir/first.log")" ||
  { echo "FAIL: no 'seed N, trace FILE, rerun: ...' line:"; cat "$dir/first.log"; exit 1; }
echo "$line"
trace="$(sed -E 's/^  seed [0-9]+, trace ([^,]+), rerun: .*/\1/' <<<"$line")"
rerun="$(sed -E 's/^.*, rerun: dca (scenario .*) \(then: .*$/\1/' <<<"$line")"
[ -s "$trace" ] || { echo "FAIL: the trace $trace is missing or empty"; exit 1; }
# shellcheck disable=SC2086  # the printed command, split into its words
(cd "$src" && "$dca" $rerun) >"$dir/again.log" 2>&1
code=$?
[ "$code" = 1 ] || { echo "FAIL: the re-run should fail again (exit 1), got $code:"; cat "$dir/again.log"; exit 1; }
# the failing step and its message, without the wall-clock stamps (t=...) of the real backend
failure() { grep -A3 '^FAIL' "$1" | sed -E 's/ \(t=[0-9.]+\)//' | grep -v '^  seed '; }
if ! diff <(failure "$dir/first.log") <(failure "$dir/again.log"); then
  echo "FAIL: the re-run failed differently (logs in $dir)"; exit 1
fi
if ! "$dca" trace diff "$trace" "$trace.again"; then
  echo "FAIL: the re-run's trace differs (kept: $trace, $trace.again)"; exit 1
fi
failure "$dir/first.log" | head -2
echo "PASS: the failure and its trace ($(wc -l <"$trace") lines) repeat"
rm -rf "$dir" "$trace" "$trace.again"
