#!/usr/bin/env bash
# The units `dca deploy` writes make a working fleet (docs/deploy.md, "dca deploy"): three network namespaces
# stand for three machines; `dca deploy` writes the units of scripts/systems/test_three_hosts.dca's hosts at the
# namespaces' addresses; each namespace's daemon is started with its unit's ExecStart as written (only the
# package's paths replaced: this dca, this test's key and state folders); then `dca run --hosts` with the hosts
# file dca deploy wrote runs the system across them to DONE.
# Needs root; where namespaces cannot be made it says why and exits 77 (skipped).
#   tests/netns/deploy.sh [DCA_EXE]
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "${1:-}" "dcd$$" 10.214.0 vision platform manip

netns_up
port=7414
lab="$work/lab.hosts"
for i in 0 1 2; do echo "${names[$i]} ${addrs[$i]}:$port" >> "$lab"; done
"$dca" deploy "$src/scripts/systems/test_three_hosts.dca" --hosts "$lab" -o "$work/deploy" > "$work/deploy.out" 2>&1 ||
  fail "dca deploy: $(cat "$work/deploy.out")"

for i in 0 1 2; do
  n="${names[$i]}"
  unit="$work/deploy/units/$n/dca-daemon.service"
  exec_line="$(grep '^ExecStart=' "$unit" | cut -d= -f2-)"
  # the package's paths: /usr/bin/dca, /etc/dca/key, %S (systemd's /var/lib)
  exec_line="${exec_line/\/usr\/bin\/dca /$dca }"
  exec_line="${exec_line/--key \/etc\/dca\/key/--key $key}"
  exec_line="${exec_line/\%S\/dca/$work/state/$n}"
  case "$exec_line" in *[\"\'%\$]*) fail "the unit of $n needs quoting this test does not do: $exec_line";; esac
  echo "$n: $exec_line"
  # shellcheck disable=SC2086
  ip netns exec "${ns[$i]}" $exec_line > "$work/$n.log" 2>&1 &
  pids+=($!)
done
wait_listening

DCA_KEY_FILE="$key" "$dca" run "$src/scripts/systems/test_three_hosts.dca" --hosts "$work/deploy/hosts" \
  > "$work/run.out" 2>&1
rc=$?
tail -3 "$work/run.out"
[ "$rc" -eq 0 ] || fail "dca run exited $rc: $(cat "$work/run.out")"
grep -q "main: DONE 30" "$work/run.out" || fail "the run did not end DONE 30"
echo "PASS"
