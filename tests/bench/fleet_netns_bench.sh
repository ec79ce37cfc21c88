#!/usr/bin/env bash
# Time to add a robot to a running fleet, and to roll a package to its robots, in network namespaces
# (BENCHMARKS.md format; docs/deploy.md, "A fleet that changes while running", "Rolling upgrade of a package"):
# the system and the ten namespaces of netns.fleet (tests/netns/fleet.sh: base, the
# door robot with the door world on its host, eight light robots r1..r8 of a template), in simulated time paced
# to the wall clock (--sim door --realtime --world-host door), each step typed through `dca repl` from the root
# namespace as an admin does, timed on the wall clock from before `dca repl` starts to the line that ends it in
# `dca run`'s output (polled every 2 ms):
#   RESULT bench=fleet_add_robot variant=netns_10_sim_paced n=.. p50_us=.. ...
#     add_child("lights", "rN") to `main.lights_rN.light: running`: rN's daemon spawns and configures the
#     robot's supervisor, which spawns its Counter's node (on the clock), wired and run
#   RESULT bench=leaf_restart_repl variant=netns_10_sim_paced n=.. ...
#     the baseline, alternated with the adds (A B A B): restart("heartbeat") to `main.heartbeat: restarted`, a
#     fresh node of one leaf on base started, on the clock, wired and run (what any start of a process pays; an
#     add pays it twice, a supervisor and its leaf, on another host)
#   RESULT bench=fleet_remove_robot variant=netns_10_sim_paced n=.. ...
#     remove_child("lights_rN") to `main.lights_rN: removed`: the leaf stopped, the subtree shut down, both
#     processes ended, the change recorded in the repository
#   RESULT bench=repl_roundtrip variant=netns_10_sim_paced n=.. ...
#     what every figure above includes: `dca repl` started, connected, `clock()` answered, ended
#   RESULT bench=fleet_roll_8_hosts variant=netns_10_sim_paced n=.. ...
#     `dca upgrade` of a rebuilt pkg_ok (each light robot's PkgScale) to its exit: the plan (each host's daemon
#     asked), then host by host, canary r1 first, unwatched (--watch 0): installed, the host's leaf restarted live
#   RESULT bench=fleet_roll_crashing_canary_rollback variant=netns_10_sim_paced n=.. ...
#     `dca upgrade` of a build that aborts at its first sample to its exit (code 1): installed on the canary r1,
#     restarted, its crash seen, rolled back, the other hosts untouched
#   RESULT bench=leaf_live_restart_repl variant=netns_10_sim_paced n=.. ...
#     the baseline, alternated with the rolls: restart("lights_r8.scale") through `dca repl`, one leaf of the
#     package started anew live (what a roll pays per host, besides the install)
# Every figure pays one `dca repl` (or `dca upgrade`) start and its connection. Needs root (exit 77 without: skipped).
#   tests/bench/fleet_netns_bench.sh [DCA_EXE] [ROUNDS]   (each round adds and removes the eight; default 3)
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/../netns/lib.sh" "${1:-}" "dcb$$" 10.220.0 base door r1 r2 r3 r4 r5 r6 r7 r8
rounds="${2:-3}"
exec 3>&1 1>&2  # RESULT lines on stdout (fd 3), everything else on stderr
eval "$(declare -f fail | sed '1s/^fail/lib_fail/')"
fail() { lib_fail "$@" >&2; }  # (also from a step whose output goes to a file)

. "$(dirname "${BASH_SOURCE[0]}")/../netns/fleet_lib.sh"
netns_up
fleet_up 7420

# timed LINE PATTERN: the wall time in us from typing LINE to the next line of the run matching PATTERN
timed() {
  local before t0 t1
  before=$(grep -c -- "$2" "$work/run.out")
  t0=${EPOCHREALTIME/./}
  printf '%s\n' "$1" | "$dca" repl main --daemon "$root" --key "$key" >> "$work/repl.out" 2>&1
  while [ "$(grep -c -- "$2" "$work/run.out")" -le "$before" ]; do
    kill -0 "$run_pid" 2>/dev/null || fail "dca run ended"
    [ $((${EPOCHREALTIME/./} - t0)) -lt $((wait_s * 1000000)) ] || fail "$1: no '$2' within $wait_s s"
    sleep 0.002
  done
  t1=${EPOCHREALTIME/./}
  echo $((t1 - t0))
}

result() {  # result BENCH FILE (one sample in us a line)
  sort -n "$2" | awk -v b="$1" '
    function q(p,  i) { i = int(p * NR); if (i < p * NR) i++; if (i < 1) i = 1; return s[i] }
    { s[NR] = $1 }
    END { printf "RESULT bench=%s variant=netns_10_sim_paced n=%d p50_us=%d p99_us=%d p999_us=%d max_us=%d\n",
            b, NR, q(0.5), q(0.99), q(0.999), s[NR] }' >&3
}

: > "$work/adds"; : > "$work/restarts"; : > "$work/removes"; : > "$work/repls"
for r in $(seq 1 "$rounds"); do
  for i in 1 2 3 4 5 6 7 8; do
    timed "add_child(\"lights\", \"r$i\")" "main.lights_r$i.light: running" >> "$work/adds"
    timed 'restart("heartbeat")' "main.heartbeat: restarted" >> "$work/restarts"
    t0=${EPOCHREALTIME/./}
    printf '%s\n' 'clock()' | "$dca" repl main --daemon "$root" --key "$key" >> "$work/repl.out" 2>&1
    echo $((${EPOCHREALTIME/./} - t0)) >> "$work/repls"
  done
  for i in 1 2 3 4 5 6 7 8; do
    timed "remove_child(\"lights_r$i\")" "main.lights_r$i: removed" >> "$work/removes"
  done
  echo "round $r of $rounds done"
done
result fleet_add_robot "$work/adds"
result leaf_restart_repl "$work/restarts"
result fleet_remove_robot "$work/removes"
result repl_roundtrip "$work/repls"

# Rolls of pkg_ok to the eight robots (each robot's scale: one leaf of the package per host), each timed from
# `dca upgrade` started to its exit, alternated with the baseline, a live restart of one such leaf typed in the
# console (`restart("lights_r8.scale")`, answered once the fresh node runs, wired)
for i in 1 2 3 4 5 6 7 8; do timed "add_child(\"lights\", \"r$i\")" "main.lights_r$i.scale: running" > /dev/null; done
# timed_cmd EXPECTED-EXIT CMD...: the wall time in us of CMD, which must exit so
timed_cmd() {
  local want=$1 t0 rc; shift
  t0=${EPOCHREALTIME/./}
  "$@" >> "$work/upgrade.out" 2>&1; rc=$?
  [ "$rc" -eq "$want" ] || fail "$*: exit code $rc, not $want: $(tail -5 "$work/upgrade.out")"
  echo $((${EPOCHREALTIME/./} - t0))
}
: > "$work/rolls"; : > "$work/rollbacks"; : > "$work/leaf_restarts"
for r in $(seq 1 "$rounds"); do
  timed_cmd 1 upgrade "$pk/variants/crash" 60 >> "$work/rollbacks"
  timed_cmd 0 repl 'restart("lights_r8.scale")' >> "$work/leaf_restarts"
  timed_cmd 0 upgrade "$pk/variants/k3" 0 >> "$work/rolls"
  timed_cmd 0 repl 'restart("lights_r8.scale")' >> "$work/leaf_restarts"
  timed_cmd 0 upgrade "$pk/pkg_ok.dca.so" 0 >> "$work/rolls"  # (pkg_ok as it was: a roll like any other)
  echo "roll round $r of $rounds done"
done
result fleet_roll_8_hosts "$work/rolls"
result fleet_roll_crashing_canary_rollback "$work/rollbacks"
result leaf_live_restart_repl "$work/leaf_restarts"
kill -INT "$run_pid"
wait "$run_pid"
exit 0
