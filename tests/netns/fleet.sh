#!/usr/bin/env bash
# A fleet across network namespaces (docs/supervision.md, "A fleet"): ten daemons, each in its own namespace on a
# bridge: base (the root's host), door (a door robot's Counter) and eight light robots r1..r8. The system declares
# the light robots as a template; while it runs, the eight join through `dca repl` (add_child), each robot's
# supervisor and Counter in its own namespace, then two leave (remove_child), their processes gone, the others
# running on. Needs root; where namespaces cannot be made it says why and exits 77 (skipped).
#   tests/netns/fleet.sh [DCA_EXE]
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "${1:-}" "dcq$$" 10.218.0 base door r1 r2 r3 r4 r5 r6 r7 r8

netns_up
daemons_up 7418

sys="$work/fleet.dca"
cat > "$sys" <<'DCA'
process Robot(h, period) {
  instantiated_processes { light instof Counter(h, period); }
  internal_event_actions { light }
}
process main() {
  host { "base" }
  supervision { strategy one_for_one; intensity 5 in 10 s; restart on crash, lost; }
  instantiated_processes {
    door instof Counter("door", 0.05);
    lights instances of Robot(0.05) on { "r1", "r2", "r3", "r4", "r5", "r6", "r7", "r8" };
  }
  internal_event_actions { door }
}
DCA
DCA_KEY_FILE="$key" "$dca" run "$sys" --hosts "$hosts" > "$work/run.out" 2>&1 &
run_pid=$!
for _ in $(seq 1 1000); do grep -qs "main.door: running" "$work/run.out" && break; sleep 0.01; done
grep -q "main.door: running" "$work/run.out" || { cat "$work/run.out"; fail "the door never ran"; }
root=$(grep -o "console: dca repl main --daemon [^ ]*" "$work/run.out" | awk '{print $NF}')
[ -n "$root" ] || { cat "$work/run.out"; fail "no console address"; }
repl() { printf '%s\n' "$@" | "$dca" repl main --daemon "$root" --key "$key" 2>&1; }

# the namespace of the (first) process whose command line holds NAME, or nothing
ns_of() { local p; p=$(pgrep -f -- "--name $1( |$)" | head -1); [ -n "$p" ] && ip netns identify "$p"; }

out=$(repl 'add_child("lights", "r1")' 'add_child("lights", "r2")' 'add_child("lights", "r3")' \
  'add_child("lights", "r4")' 'add_child("lights", "r5")' 'add_child("lights", "r6")' 'add_child("lights", "r7")' \
  'add_child("lights", "r8")')
echo "$out"
for i in 1 2 3 4 5 6 7 8; do
  echo "$out" | grep -q "main.lights_r$i: added on host r$i" || fail "r$i did not join: $out"
done
# each light runs, in its robot's namespace (r1 is names[2], its namespace ns[2])
for i in 1 2 3 4 5 6 7 8; do
  for _ in $(seq 1 500); do grep -q "main.lights_r$i.light: running" "$work/run.out" && break; sleep 0.01; done
  grep -q "main.lights_r$i.light: running" "$work/run.out" || fail "the light of r$i never ran"
  got=$(ns_of "main.lights_r$i.light")
  [ "$got" = "${ns[$((i + 1))]}" ] || fail "main.lights_r$i.light runs in namespace '$got', not r$i's ${ns[$((i + 1))]}"
  got=$(ns_of "main.lights_r$i")
  [ "$got" = "${ns[$((i + 1))]}" ] || fail "main.lights_r$i's supervisor runs in namespace '$got', not ${ns[$((i + 1))]}"
done
echo "eight robots joined, each in its own namespace"

out=$(repl 'remove_child("lights_r3")' 'remove_child("lights", "r6")' 'fleet()')
echo "$out"
echo "$out" | grep -q "main.lights_r3: removed" || fail "r3 did not leave"
echo "$out" | grep -q "main.lights_r6: removed" || fail "r6 did not leave"
echo "$out" | grep -q "main.lights_r8 on r8 (running)" || fail "r8 does not run on"
for i in 3 6; do
  for _ in $(seq 1 200); do pgrep -f -- "--name main.lights_r$i" >/dev/null || break; sleep 0.01; done
  pgrep -f -- "--name main.lights_r$i" >/dev/null && fail "a process of main.lights_r$i is still there"
done
[ "$(echo "$out" | grep -o "(running)" | wc -l)" -eq 6 ] || fail "not six robots running: $out"
kill -0 "$run_pid" 2>/dev/null || fail "dca run ended"

kill -INT "$run_pid"
wait "$run_pid"
cat "$work/run.out"
grep -q "interrupted (SIGINT): stopping" "$work/run.out" || fail "dca run did not stop on SIGINT"
echo "PASS"
