#!/usr/bin/env bash
# Three hosts in three network namespaces: one dca daemon in each (ip netns + veth pairs on a bridge), a
# three-host system run across them with `dca run --hosts`, and a check that the data flows host to host
# directly (the Counter on "vision" feeds the Threshold on "manip" over a TCP connection between those two
# namespaces, not through a supervisor: the supervisor of that connection's group runs on "platform").
# Needs root; where namespaces cannot be made it says why and exits 77, which CTest reports as skipped
# (SKIP_RETURN_CODE), never as passed.
#   tests/netns/three_hosts.sh [DCA_EXE]
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "${1:-}" "dca$$" 10.213.0 vision platform manip

netns_up
daemons_up 7411
echo "three daemons up: $(tr '\n' ' ' < "$hosts")"

# the system: Counter (vision) -> Threshold at 300 (manip), Constant (platform) -> Gain (manip); about 3 s
sys="$work/netns_chain.dca"
sed -e 's/Threshold(h, 30)/Threshold(h, 300)/' "$src/scripts/systems/test_three_hosts.dca" > "$sys"
DCA_KEY_FILE="$key" "$dca" run "$sys" --hosts "$hosts" > "$work/run.out" 2>&1 &
run_pid=$!

# while it runs: the Threshold's node (on manip) must have an established TCP connection from vision's
# address to one of its own listening ports: the data connection from the Counter, host to host
direct=""
for _ in $(seq 1 30000); do  # until the run ends (it is bounded by its own timeout)
  node=$(pgrep -f -- "node --type Threshold --name main.chain.det.level" | head -1)
  if [ -n "$node" ]; then
    ports=$(ip netns exec "${ns[2]}" ss -tlnpH 2>/dev/null | grep "pid=$node," | awk '{print $4}' | sed 's/.*://')
    for p in $ports; do
      if ip netns exec "${ns[2]}" ss -tnH state established 2>/dev/null | awk '{print $3, $4}' |
         grep -q "${addrs[2]}:$p ${addrs[0]}:"; then direct="port $p"; fi
    done
  fi
  [ -n "$direct" ] && break
  kill -0 "$run_pid" 2>/dev/null || break
  sleep 0.01
done
wait "$run_pid"
rc=$?
cat "$work/run.out"
[ "$rc" -eq 0 ] || fail "dca run exited $rc"
grep -q "main: DONE 300" "$work/run.out" || fail "the run did not end DONE 300"
[ -n "$direct" ] || fail "no direct TCP connection from vision (${addrs[0]}) to the Threshold's node on manip"
echo "data flows vision -> manip directly ($direct)"
echo "PASS"
