#!/usr/bin/env bash
# One supervised run of the paper's door-opening system in simulated time, as the demo runs it:
#   worlds/door/tests/runs/door_run.sh DCA_EXE SEED [dca run options...]
# Passes when `dca run` ends DONE (exit 0) and the world's summary says the door opened to at least 70 degrees
# (DOOR_MIN and DOOR_MAX in the environment change the bounds). Prints the run's output (the steps and the
# summary) either way.
set -uo pipefail
dca="$1"; seed="$2"; shift 2
src="${DCA_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
"$dca" run "$src/worlds/door/systems/door_open.dca" --sim door --seed "$seed" "$@" >"$log" 2>&1
code=$?
grep -v " broken " "$log" | tail -40
angle=$(sed -n 's/^door opened to \([0-9.-]*\) deg.*/\1/p' "$log" | tail -1)
[ "$code" -eq 0 ] || { echo "FAIL: seed $seed: dca run exited $code (door at ${angle:-?} deg)"; exit 1; }
min="${DOOR_MIN:-70}"; max="${DOOR_MAX:-180}"
awk -v a="${angle:-0}" -v lo="$min" -v hi="$max" 'BEGIN { exit !(a >= lo && a <= hi) }' ||
  { echo "FAIL: seed $seed: the door opened to ${angle:-?} deg, not between $min and $max"; exit 1; }
# DOOR_PROCESSES: at most that many processes advanced per lock-step round (a placement's shared nodes take one
# advance each, whatever the number of their leaves; a few rounds more for the subscriptions at the start), and
# two more per barrier (after an event every node is advanced to t before the supervisors quiesce, and again after)
if [ -n "${DOOR_PROCESSES:-}" ]; then
  read -r rounds advances barriers < <(sed -n \
    's/^lock-step: \([0-9]*\) rounds, \([0-9]*\) advances.*; \([0-9]*\) barriers$/\1 \2 \3/p' "$log" | tail -1)
  awk -v r="${rounds:-0}" -v a="${advances:-0}" -v b="${barriers:-0}" -v n="$DOOR_PROCESSES" \
    'BEGIN { exit !(r > 0 && a <= n * (r + 3 + 2 * b)) }' ||
    { echo "FAIL: seed $seed: $advances advances in $rounds rounds: more than $DOOR_PROCESSES processes a round"; exit 1; }
  echo "lock-step: $advances advances in $rounds rounds and $barriers barriers, at most $DOOR_PROCESSES processes a round"
fi
echo "PASS: seed $seed: the door opened to $angle deg"
