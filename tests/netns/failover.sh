#!/usr/bin/env bash
# Failover across network namespaces (docs/supervision.md, "Failover"): three daemons, each in its own
# namespace on a bridge; a Counter on "manip" (standby host "base") feeds a Threshold on "base" over TCP between
# the namespaces. Once it runs, manip is lost (its daemon SIGKILLed, its processes with it, as
# tests/scenarios/host_lost.lua does): the root's policy (`restart on lost`) restarts the Counter on base, its
# link to the Threshold is made again (now a Unix socket within base's namespace), the count starts again and
# the run ends DONE 100. Needs root; where namespaces cannot be made it says why and exits 77 (skipped).
#   tests/netns/failover.sh [DCA_EXE]
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "${1:-}" "dcf$$" 10.215.0 base manip spare

netns_up
daemons_up 7413

sys="$work/failover.dca"
cat > "$sys" <<'DCA'
process main() {
  host { "base" }
  supervision { strategy one_for_one; intensity 3 in 10 s; restart on lost; standby count on "base"; fence 2 s margin 0.25 s; }
  instantiated_processes {
    count instof Counter("manip", 0.01);
    det   instof Threshold("base", 100);
  }
  internal_connections(count, run) { count, Count -> det, In; }
  internal_event_actions { det # count[run] }
}
DCA
DCA_KEY_FILE="$key" "$dca" run "$sys" --hosts "$hosts" > "$work/run.out" 2>&1 &
run_pid=$!
for _ in $(seq 1 500); do grep -qs "main.count: running" "$work/run.out" && break; sleep 0.01; done
grep -q "main.count: running" "$work/run.out" || { cat "$work/run.out"; fail "the Counter never ran"; }

# manip lost: its processes held (SIGSTOP) so they neither close their channels nor stop in order, its daemon
# killed, then its processes
children=$(pgrep -P "${pids[1]}")
for p in $children; do kill -STOP "$p"; done
kill -KILL "${pids[1]}"
for p in $children; do kill -KILL "$p"; done

wait "$run_pid"
rc=$?
cat "$work/run.out"
[ "$rc" -eq 0 ] || fail "dca run exited $rc"
grep -q "main.count: moves from host manip to host base" "$work/run.out" || fail "no failover line"
grep -q "main.count: restarted" "$work/run.out" || fail "no restart line"
grep -q "main: DONE 100" "$work/run.out" || fail "the run did not end DONE 100"
echo "PASS"
