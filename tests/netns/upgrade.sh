#!/usr/bin/env bash
# A rolling upgrade of a controller package across three network namespaces (docs/deploy.md, "Rolling upgrade of
# a package"): a daemon in each (h1, h2, h3, each with its own state folder: its package store), three robots
# (tests/lua/launch/upgrade_robots.dca, the test package pkg_ok beside it) run across them with `dca run --hosts`;
# then `dca upgrade` from outside the namespaces, with the cluster key:
#   - a build that aborts at its first sample, canary h2: rolled back on h2, h1 and h3 never receive it (their
#     stores stay empty), exit code 1;
#   - the k = 3 rebuild: every host's store holds it, exit code 0, and the repository records it.
# Needs root; where namespaces cannot be made it says why and exits 77 (skipped).
#   tests/netns/upgrade.sh [DCA_EXE]
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "${1:-}" "dcu$$" 10.219.0 h1 h2 h3
pk="${DCA_TEST_PACKAGES_DIR:?DCA_TEST_PACKAGES_DIR is not set}"

netns_up
daemons_up 7419 --state-dir "$work/state/{host}"
mkdir -p "$work/sys/packages" && cp "$pk/pkg_ok.dca.so" "$work/sys/packages/" &&
  cp "$src/tests/lua/launch/upgrade_robots.dca" "$work/sys/robots.dca" || fail "the system's folder"

DCA_KEY_FILE="$key" "$dca" run "$work/sys/robots.dca" --hosts "$hosts" > "$work/run.out" 2>&1 &
run_pid=$!
for _ in $(seq 1 6000); do  # its own line says when it is up (bounded: 60 s)
  grep -q "whole tree is configured" "$work/run.out" && break
  kill -0 "$run_pid" 2>/dev/null || break
  sleep 0.01
done
grep -q "whole tree is configured" "$work/run.out" || fail "dca run did not come up: $(tail -20 "$work/run.out")"
daemon=$(sed -n 's/.*console: dca repl main --daemon \([^ ]*\) --key.*/\1/p' "$work/run.out" | head -1)
[ -n "$daemon" ] || fail "dca run named no console"
upgrade() { "$dca" upgrade "$1" --system main --daemon "$daemon" --key "$key" --canary h2 --watch "$2"; }
store() { echo "$work/state/$1/packages/$2/pkg_ok.dca.so"; }

out=$(upgrade "$pk/variants/crash" 60 2>&1); rc=$?
echo "$out"
[ "$rc" -eq 1 ] || fail "a crashing canary: exit code $rc, not 1"
echo "$out" | grep -q "^upgrade pkg_ok: h2: failed: main.r2.sc: exited: killed by SIGABRT on host h2" ||
  fail "the canary's crash is not why it failed"
echo "$out" | grep -q "^upgrade pkg_ok: rolled back on h2 and stopped (h1, h3 never received version " ||
  fail "not rolled back"
[ ! -e "$(store h2 current)" ] && cmp -s "$(store h2 previous)" "$pk/variants/crash/pkg_ok.dca.so" ||
  fail "h2's store: the bad build is not the previous one, or something is installed"
for h in h1 h3; do [ ! -e "$work/state/$h/packages" ] || fail "$h received a package"; done

out=$(upgrade "$pk/variants/k3" 0.5 2>&1); rc=$?
echo "$out"
[ "$rc" -eq 0 ] || fail "the k = 3 build: exit code $rc"
echo "$out" | grep -q "^upgrade pkg_ok: done: 3 hosts run version [0-9a-f]* (h2, h1, h3)$" || fail "not done"
for h in h1 h2 h3; do cmp -s "$(store $h current)" "$pk/variants/k3/pkg_ok.dca.so" || fail "$h does not hold it"; done
rec=$("$dca" config get upgrade.pkg_ok --daemon "${addrs[2]}:7419" --key "$key" 2>&1)
echo "h3's repository: $rec"
echo "$rec" | grep -q 'state = "done"' || fail "the repository of h3 has no record of the upgrade"
grep -q "upgrade pkg_ok: done: 3 hosts" "$work/run.out" || fail "the run's output does not say it"

kill -TERM "$run_pid"
wait "$run_pid"
echo "PASS"
