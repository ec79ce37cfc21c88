#!/usr/bin/env bash
# A fleet across network namespaces (docs/supervision.md, "A fleet"; docs/deploy.md, "A fleet that changes while
# running", "Rolling upgrade of a package"): ten daemons, each in its own namespace on a bridge: base (the root's
# host), door (the door robot: the door system's controllers and its world, the door of worlds/door in Simbody)
# and eight light robots r1..r8 (a template: a Counter feeding PkgScale, of the test package pkg_ok). The run is
# in simulated time paced to the wall clock (`--sim door --realtime --world-host door`: a robot in a fleet moves
# in real time; every node, the added ones too, in lock-step with the door's world; tests/netns/fleet_lib.sh).
# While the door robot opens the door, the eight light robots join through `dca repl` (add_child), each robot's
# supervisor and Counter in its own namespace and on the clock (their counts advance); then two leave
# (remove_child), their processes gone, the others running on. `dca upgrade` then rolls a rebuilt pkg_ok that
# crashes: rolled back on its canary r1, no other robot receives it; then a good rebuild (k = 3) to the six
# robots, each robot's scale running it. The door opens meanwhile. At the end every replica of the configuration
# repository (the ten daemons') holds the fleet's ten changes (`fleet.main.lights`) in order, and the same
# transactions as base's (the rolls' records too), numbered 1..N without a gap.
# Every wait is a poll bounded by 60 s (wait_for, lib.sh: a loaded 2-core machine, ASan), never a fixed sleep.
# Needs root; where namespaces cannot be made it says why and exits 77 (skipped).
#   tests/netns/fleet.sh [DCA_EXE]
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "${1:-}" "dcq$$" 10.218.0 base door r1 r2 r3 r4 r5 r6 r7 r8
. "$(dirname "${BASH_SOURCE[0]}")/fleet_lib.sh"
eval "$(declare -f fail | sed '1s/^fail/lib_fail/')"
fail() { echo "--- dca run, its last 100 lines:"; tail -100 "$work/run.out" 2>/dev/null; lib_fail "$@"; }
netns_up
fleet_up 7418

# the namespace of the (first) process whose command line matches the pattern, or nothing
ours() { pgrep -P "$(IFS=,; echo "${pids[*]}")" -f -- "$1"; }  # our daemons' children matching (not another test's)
ns_of() { local p; p=$(ours "$1" | head -1); [ -n "$p" ] && ip netns identify "$p"; }
said "world: starting \`dca sim --serve --world door\` on host door" || fail "the world was not started on door"
got=$(ns_of "dca sim --serve .*--world door")
[ "$got" = "${ns[1]}" ] || fail "the door's world runs in namespace '$got', not door's ${ns[1]}"
got=$(ns_of "--name main.door.motionctrl.puma( |$)")
[ "$got" = "${ns[1]}" ] || fail "the door robot's arm controller runs in namespace '$got', not door's ${ns[1]}"

# the fleet's changes in the order made: the hosts with an instance after each (fleet.main.lights' `hosts`)
changes=()
members=()
change() {  # change added|removed HOST
  if [ "$1" = added ]; then members+=("$2"); else
    local m=() h; for h in "${members[@]}"; do [ "$h" = "$2" ] || m+=("$h"); done; members=("${m[@]}")
  fi
  local q=() h; for h in "${members[@]}"; do q+=("\"$h\""); done
  changes+=("{ hosts = { $(IFS=,; echo "${q[*]}" | sed 's/,/, /g') }, last = { instance = \"lights_$2\", what = \"$1\" } }")
}

adds=()
for i in 1 2 3 4 5 6 7 8; do adds+=("add_child(\"lights\", \"r$i\")"); done
out=$(repl "${adds[@]}")
echo "$out"
for i in 1 2 3 4 5 6 7 8; do
  echo "$out" | grep -q "main.lights_r$i: added on host r$i" || fail "r$i did not join: $out"
  change added "r$i"
done
# each light runs in its robot's namespace (r1 is names[2], its namespace ns[2]), on the clock: its count advances
count() { repl "read(\"lights_r$1.light\", \"Count\")" | awk '/samples\)$/ { print $1 }'; }
counted() { local n; n=$(count "$1"); [ -n "$n" ] && [ "$n" -ge 5 ]; }
for i in 1 2 3 4 5 6 7 8; do
  wait_for said "main.lights_r$i.light: running" || fail "the light of r$i never ran"
  got=$(ns_of "--name main.lights_r$i.light( |$)")
  [ "$got" = "${ns[$((i + 1))]}" ] || fail "main.lights_r$i.light runs in namespace '$got', not r$i's ${ns[$((i + 1))]}"
  got=$(ns_of "--name main.lights_r$i( |$)")
  [ "$got" = "${ns[$((i + 1))]}" ] || fail "main.lights_r$i's supervisor runs in namespace '$got', not ${ns[$((i + 1))]}"
  wait_for counted "$i" || fail "the light of r$i does not count on the clock: $(count "$i")"
done
echo "eight robots joined, each in its own namespace, each counting in simulated time"

out=$(repl 'remove_child("lights_r3")' 'remove_child("lights", "r6")' 'fleet()')
echo "$out"
echo "$out" | grep -q "main.lights_r3: removed" || fail "r3 did not leave"
change removed r3
echo "$out" | grep -q "main.lights_r6: removed" || fail "r6 did not leave"
change removed r6
echo "$out" | grep -q "main.lights_r8 on r8 (running)" || fail "r8 does not run on"
gone() { ! ours "--name main.lights_r$1" >/dev/null; }
for i in 3 6; do wait_for gone "$i" || fail "a process of main.lights_r$i is still there"; done
[ "$(echo "$out" | grep -o "(running)" | wc -l)" -eq 6 ] || fail "not six robots running: $out"
n8=$(count 8)
more() { local n; n=$(count 8); [ -n "$n" ] && [ "$n" -gt "$n8" ]; }
wait_for more || fail "r8 stopped counting after the removes"

# a rebuilt pkg_ok that aborts at its first sample, canary r1: rolled back there, no other robot receives it
store() { echo "$work/state/$1/packages/$2/pkg_ok.dca.so"; }
out=$(upgrade "$pk/variants/crash" 60); rc=$?
echo "$out"
[ "$rc" -eq 1 ] || fail "a crashing canary: exit code $rc, not 1"
echo "$out" | grep -q "^upgrade pkg_ok: r1: failed: main.lights_r1.scale: exited: killed by SIGABRT on host r1" ||
  fail "the canary's crash is not why it failed"
echo "$out" | grep -q "^upgrade pkg_ok: rolled back on r1 and stopped (r2, r4, r5, r7, r8 never received version " ||
  fail "not rolled back"
[ ! -e "$(store r1 current)" ] && cmp -s "$(store r1 previous)" "$pk/variants/crash/pkg_ok.dca.so" ||
  fail "r1's store: the bad build is not the previous one, or something is installed"
for h in r2 r4 r5 r7 r8; do [ ! -e "$work/state/$h/packages" ] || fail "$h received the bad build"; done
# r1's scale runs its old build again (k = 2: Out = 2 In; the bad build never writes), after one crash only.
# gain N: robot N's scale's Out / In, read one after the other in one line (an event-driven leaf on the simulated
# clock takes its samples in at the idle ticks, a second apart: both reads see the same tick but at its edge)
gain() { repl "local i = read(\"lights_r$1.scale\", \"In\") local o = read(\"lights_r$1.scale\", \"Out\") return o / i" |
  sed -n '2p'; }
gain_is() { [ "$(gain "$1")" = "$2" ]; }
wait_for gain_is 1 2.0 || fail "r1's scale does not run its old build after the rollback: Out / In $(gain 1)"
[ "$(grep -c "\] main.lights_r1.scale: exited: killed by SIGABRT" "$work/run.out")" -eq 1 ] ||
  fail "r1's scale crashed more than once: the group's restart loaded the bad build"
# the good rebuild (k = 3) to every robot, canary first; each robot's scale restarted live onto it, runs on
out=$(upgrade "$pk/variants/k3" 0.5); rc=$?
echo "$out"
[ "$rc" -eq 0 ] || fail "the k = 3 build: exit code $rc"
echo "$out" | grep -q "^upgrade pkg_ok: done: 6 hosts run version [0-9a-f]* (r1, r2, r4, r5, r7, r8)$" || fail "not done"
for h in r1 r2 r4 r5 r7 r8; do
  cmp -s "$(store $h current)" "$pk/variants/k3/pkg_ok.dca.so" || fail "$h does not hold the k = 3 build"
done
# each robot's scale runs the k = 3 build
for h in 1 2 4 5 7 8; do wait_for gain_is $h 3.0 || fail "r$h's scale does not run the k = 3 build: Out / In $(gain $h)"; done

# the door robot opens the door meanwhile: its DoorOpenSystem ends DONE with the angle (door.open_angle: 75 deg)
wait_for said "main.door: done" || fail "the door robot did not open the door"
angle=$(sed -n 's/.*main\.door: done \([0-9.]*\)$/\1/p' "$work/run.out")
awk -v a="$angle" 'BEGIN { exit !(a >= 75) }' || fail "the door opened to '$angle' deg only"
echo "the door robot opened the door to $angle deg"
kill -0 "$run_pid" 2>/dev/null || fail "dca run ended"

# nothing lost in the configuration repository: every replica holds the ten changes, in the order made (one
# origin, the root's host base: its sequence numbers order them), and the last is the fleet now
fleet_log() {  # the values of fleet.main.lights in daemon $1's log, oldest first
  "$dca" config log 500 --daemon "$1" --key "$key" 2>&1 |
    sed -n 's/^  \([^ ]*\) #\([0-9]*\) .*fleet\.main\.lights = \(.*\)$/\2 \1 \3/p' | sort -n | cut -d' ' -f2-
}
want=$(for c in "${changes[@]}"; do echo "$c"; done)
holds_all() { [ "$(fleet_log "$1" | cut -d' ' -f2-)" = "$want" ]; }
for i in "${!names[@]}"; do
  addr="${addrs[$i]}:7418"
  wait_for holds_all "$addr" || fail "the replica of ${names[$i]} lacks changes or has them out of order:
$(fleet_log "$addr")
--- wanted:
$want"
  origins=$(fleet_log "$addr" | cut -d' ' -f1 | sort -u)
  [ "$(echo "$origins" | wc -l)" -eq 1 ] && [ "${origins%%/*}" = base ] ||
    fail "the fleet's changes on ${names[$i]} come from '$origins', not from base's replica alone"
  "$dca" config log 500 --daemon "$addr" --key "$key" 2>&1 | grep -q "^conflicts, newest first: none$" ||
    fail "conflicts in the replica of ${names[$i]}"
done
echo "every replica holds the fleet's ${#changes[@]} changes in order"
# and the two rolls' records (upgrade.pkg_ok's states in order), and every transaction of base's replica, the
# same on every replica, its sequence numbers 1..N without a gap
states() {
  "$dca" config log 500 --daemon "$1" --key "$key" 2>&1 |
    sed -n 's/^  [^ ]* #\([0-9]*\) .*upgrade\.pkg_ok = .*state = "\([^"]*\)".*/\1 \2/p' | sort -n | cut -d' ' -f2- |
    tr '\n' ,
}
txns() {
  "$dca" config log 500 --daemon "$1" --key "$key" 2>&1 | sed -n 's/^  \(base\/[^ ]*\) #\([0-9]*\) /\2 \1 /p' | sort -n
}
want_states="rolling,rolled back,rolling,done,"
[ "$(states "${addrs[0]}:7418")" = "$want_states" ] || fail "base's records of the rolls: $(states "${addrs[0]}:7418")"
base_txns=$(txns "${addrs[0]}:7418")
echo "$base_txns" | awk '$1 != NR { exit 1 }' || fail "base's transactions are not 1..N: $base_txns"
same() { [ "$(txns "$1")" = "$base_txns" ]; }
for i in "${!names[@]}"; do
  wait_for same "${addrs[$i]}:7418" || fail "the replica of ${names[$i]} differs from base's: $(txns "${addrs[$i]}:7418")"
done
echo "every replica holds base's $(echo "$base_txns" | wc -l) transactions, the rolls' records ($want_states) too"

kill -INT "$run_pid"
wait "$run_pid"
cat "$work/run.out"
grep -q "interrupted (SIGINT): stopping" "$work/run.out" || fail "dca run did not stop on SIGINT"
echo "PASS"
