#!/usr/bin/env bash
# Repeatable simulated time (docs/time.md): the door system, one seed, run several times
# with --trace gives the same trace, byte for byte: RUNS times as it is, once more while two busy loops burn
# both cores, once with its three hosts mapped to one daemon (Unix sockets instead of TCP between them), and
# once per placement of the leaves in shared nodes (`--placement group`, `--placement host`: in-process links).
# Any difference fails and prints `dca trace diff` (the first divergence: tick, process, port, both values),
# the seed and the trace files, which are kept for a re-run.
#   worlds/door/tests/runs/door_repeat.sh DCA_EXE SEED [RUNS] [dca run options...]
set -uo pipefail
dca="$1"; seed="$2"; runs="${3:-5}"; shift 3 2>/dev/null || shift $#
src="${DCA_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
dir="$(mktemp -d)"
burners=(); daemon=""
cleanup() {
  for p in "${burners[@]}"; do kill "$p" 2>/dev/null; done
  [ -n "$daemon" ] && kill "$daemon" 2>/dev/null
}
trap cleanup EXIT
system="$src/worlds/door/systems/door_open.dca"

one() {  # one run: NAME [extra dca run options...]
  local name="$1"; shift
  if ! "$dca" run "$system" --sim door --seed "$seed" --quiet --trace "$dir/$name.trace" "$@" >"$dir/$name.log" 2>&1; then
    echo "FAIL: seed $seed, run $name: dca run failed (log $dir/$name.log):"; tail -20 "$dir/$name.log"; exit 1
  fi
  grep -E '^(simulated|lock-step)' "$dir/$name.log" | sed "s/^/  $name: /"
  [ "$name" = first ] && return
  if ! "$dca" trace diff "$dir/first.trace" "$dir/$name.trace"; then
    echo "FAIL: seed $seed: run $name differs from the first (traces kept in $dir; re-run: $0 $dca $seed)"; exit 1
  fi
}

one first
for i in $(seq 2 "$runs"); do one "run$i"; done
for placement in group host; do one "placement_$placement" --placement "$placement"; done
# under load: two busy loops on the two cores
for _ in 1 2; do (while :; do :; done) & burners+=($!); done
one loaded
cleanup; burners=()
# three hosts, one daemon: every host name maps to it
"$dca" daemon --host one --listen "unix:$dir/daemon.sock" --key "$dir/key" --clock sim --state-dir "$dir/state" \
  >"$dir/daemon.log" 2>&1 & daemon=$!
for _ in $(seq 100); do [ -S "$dir/daemon.sock" ] && break; sleep 0.1; done
printf 'vision unix:%s\nplatform unix:%s\nmanipulation unix:%s\n' "$dir/daemon.sock" "$dir/daemon.sock" \
  "$dir/daemon.sock" >"$dir/hosts"
DCA_KEY_FILE="$dir/key" one one_daemon --hosts "$dir/hosts"
echo "PASS: seed $seed: $((runs + 4)) runs, identical traces ($(wc -l <"$dir/first.trace") lines)"
rm -rf "$dir"
