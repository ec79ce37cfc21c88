#!/usr/bin/env bash
# Fencing before failover across network namespaces (docs/supervision.md, "Fencing"; docs/safety.md): a
# JointSetpoint on "manip" (standby host "base") commands the elbow of a mock UR10 whose world runs on "base";
# `dca run` (the root supervisor) runs outside the namespaces. Once the leaf runs, manip is cut off from the
# supervisor:
#   silent: nftables `drop` rules inside manip's namespace for every packet to or from the supervisor's address
#           (manip's link to the world stays: its leaf would go on commanding the joint);
#   loud:   manip's link set down (`ip link set down`): manip reaches nobody.
# Checked each time, from the run's output, manip's daemon log and the trace (`dca run --trace`, its per-tick
# D lines: every output that wrote in that tick):
#   - manip's daemon fenced the leaf (SIGTERM) after at least `fence` (1.5 s) of silence, and nothing of the run
#     is left on manip after it;
#   - the supervisor started the standby only after fence + margin since its last renewal ("host manip fenced
#     (waited ...)" before "restarted");
#   - no tick has two writers on the joint: no refused second writer (no W line: the world takes one writer at a
#     time, docs/safety.md), no tick with D lines of main.ctrl.Cmd from two instances (a new instance counts
#     from 1 again), and the old instance's last tick comes before the new one's first;
#   - the joint's velocity went to zero before the standby wrote (the old node's halt, the world's watchdog, or
#     the world's zeroing of a writer the clock master dropped: the loud case, after the tick timeout: 5 s here).
# Repeats: DCA_FENCE_REPEATS (default 1) times each case. 20 repeats: DCA_FENCE_REPEATS=20.
# Needs root and nftables; where namespaces cannot be made it says why and exits 77 (skipped).
#   tests/netns/fence.sh [DCA_EXE]
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "${1:-}" "dfn$$" 10.216.0 base manip spare

command -v nft >/dev/null || skip "no 'nft' command (Debian's nftables)"
netns_up
repeats="${DCA_FENCE_REPEATS:-1}"
urdf="$src/worlds/ur10/ur10.urdf"
sys="$work/fence.dca"
cat > "$sys" <<'DCA'
process main() {
  host { "base" }
  supervision {
    strategy one_for_one; intensity 3 in 10 s; restart on lost; standby ctrl on "base";
    fence 1.5 s margin 0.5 s;
  }
  instantiated_processes {
    ctrl instof JointSetpoint("manip", "elbow_joint", 3.0, 0.01, "velocity", 0.01, 600);
    stop instof Timer("base", 7);
  }
  internal_event_actions { ctrl # stop }
}
DCA

# Stops this round's daemons and undoes the cut.
round_down() {
  daemons_down
  ip netns exec "${ns[1]}" nft delete table inet dcafence 2>/dev/null
  ip -n "${ns[1]}" link set "${tag}v1p" up
}

# partition CASE: manip cut off from the supervisor (at the bridge's address), silently or loudly.
partition() {
  if [ "$1" = silent ]; then
    ip netns exec "${ns[1]}" nft -f - <<NFT || fail "nft rules in ${ns[1]}"
table inet dcafence {
  chain in { type filter hook input priority 0; policy accept; ip saddr $subnet.1 drop; }
  chain out { type filter hook output priority 0; policy accept; ip daddr $subnet.1 drop; }
}
NFT
  else
    ip -n "${ns[1]}" link set "${tag}v1p" down || fail "link down in ${ns[1]}"
  fi
}

bad() { echo "--- dca run:"; cat "$work/run.out"; [ -n "${DCA_FENCE_KEEP:-}" ] && cp "$work"/run.* "$work"/*.log "$DCA_FENCE_KEEP"/; fail "$@"; }

# check CASE ROUND: the assertions of the header on this round's files; a failure shows the run's output.
check() {
  local out="$work/run.out" trace="$work/run.trace" log="$work/manip.log" what="$1 round $2"
  grep -q "main: DONE" "$out" || bad "$what: the run did not end DONE"
  local fenced
  fenced=$(grep -o "main.ctrl: fenced on host manip: its supervisor ($subnet.1:[0-9]*) was silent for [0-9.]* s (fence 1.5 s)" "$log" | head -1)
  [ -n "$fenced" ] || bad "$what: manip's daemon did not fence main.ctrl"
  awk -v s="$(echo "$fenced" | sed 's/.*silent for \([0-9.]*\) s.*/\1/')" 'BEGIN { exit !(s >= 1.5) }' ||
    bad "$what: fenced before the fence: $fenced"
  grep -q "main.ctrl: moves from host manip to host base" "$out" || bad "$what: no failover line"
  local waited restarted
  waited=$(grep -n "main.ctrl: host manip fenced (waited" "$out" | head -1 | cut -d: -f1)
  restarted=$(grep -n "main.ctrl: restarted" "$out" | head -1 | cut -d: -f1)
  [ -n "$waited" ] && [ -n "$restarted" ] && [ "$waited" -lt "$restarted" ] ||
    bad "$what: the standby did not wait for the fence before its restart"
  grep -q " W world\." "$trace" && bad "$what: a second writer was refused: $(grep -m3 ' W world\.' "$trace")"
  # per tick: at most one writer of the joint; the old instance (counts going up) ends before the new one (its
  # count from 1 again) begins; the joint's velocity at zero in between
  awk '
    $2 == "D" && $3 == "main.ctrl.Cmd" {
      n = substr($4, 3) + 0
      # (one instance may write twice in a tick: its last command and its halt zero; its count goes on)
      if ($1 == last && n <= prev) { print "two writers at tick " $1; bad = 1 }
      if (n < prev && !newfirst) { newfirst = $1; oldlast = last }
      prev = n; last = $1
    }
    $2 == "D" && $3 == "world.joint.elbow_joint.velocity" && $6 == "value=[0]" { zero[$1] = 1 }
    END {
      if (bad) exit 1
      if (!newfirst) { print "no new instance wrote"; exit 1 }
      # (a sensor line at t shows the step before t: a zero at newfirst was before the new writer acted)
      for (t in zero) if (t + 0 > oldlast + 0 && t + 0 <= newfirst + 0) z = 1
      if (!z) { print "the joint was not at zero between the old writer (" oldlast ") and the new (" newfirst ")"; exit 1 }
      printf "old writer last at %.3f s, new writer first at %.3f s\n", oldlast / 1e9, newfirst / 1e9
    }' "$trace" > "$work/ticks" || bad "$what: $(cat "$work/ticks")"
  echo "$what: $fenced; $(cat "$work/ticks"); $(grep -o 'host manip fenced (waited [0-9.]* s' "$out" | head -1)"
}

round=0
for r in $(seq 1 "$repeats"); do
  for c in silent loud; do
    round=$((round + 1))
    daemons_up $((7420 + round)) --clock sim
    # (one process per leaf, as the daemon's fence is checked per leaf: simulated time places as `host` otherwise)
    DCA_KEY_FILE="$key" timeout 120 "$dca" run "$sys" --hosts "$hosts" --sim "mock:$urdf" --realtime \
      --placement process --tick-timeout 5000 --trace "$work/run.trace" > "$work/run.out" 2>&1 &
    run_pid=$!
    for _ in $(seq 1 6000); do grep -qs "main.ctrl: running" "$work/run.out" && break; sleep 0.01; done  # (60 s at most)
    if ! grep -q "main.ctrl: running" "$work/run.out"; then
      cat "$work/run.out"
      ps -o pid,stat,wchan:24,etime,cmd -p "$run_pid" --ppid "$run_pid"
      ss -tnp 2>/dev/null | grep "pid=$run_pid,"
      fail "$c round $r: the leaf never ran"
    fi
    sleep 0.5  # (a few ticks of the old writer; nothing below depends on how many)
    partition "$c"
    wait "$run_pid"
    rc=$?
    [ "$rc" -eq 0 ] || { cat "$work/run.out"; fail "$c round $r: dca run exited $rc"; }
    # nothing of the run is left on manip (its daemon's children)
    left=$(pgrep -P "${pids[1]}" | tr '\n' ' ')
    [ -z "$left" ] || fail "$c round $r: processes left on manip after the run: $left"
    check "$c" "$r"
    round_down
  done
done
echo "PASS ($repeats repeats of each case)"
