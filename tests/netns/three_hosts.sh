#!/usr/bin/env bash
# Three hosts in three network namespaces: one dca daemon in each (ip netns + veth pairs on a bridge), a
# three-host system run across them with `dca run --hosts`, and a check that the data flows host to host
# directly (the Counter on "vision" feeds the Threshold on "manip" over a TCP connection between those two
# namespaces, not through a supervisor: the supervisor of that connection's group runs on "platform"). Needs root; where namespaces cannot be made it says why and exits 77,
# which CTest reports as skipped (SKIP_RETURN_CODE), never as passed.
#   tests/netns/three_hosts.sh [DCA_EXE]
set -uo pipefail
dca="${1:-${DCA_EXE:-dca}}"
src="${DCA_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
tag="dca$$"
ns=("${tag}a" "${tag}b" "${tag}c")
names=(vision platform manip)
addrs=(10.213.0.2 10.213.0.3 10.213.0.4)
br="${tag}br"
work="$(mktemp -d)"
pids=()

skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }

cleanup() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do
    for _ in $(seq 1 100); do kill -0 "$p" 2>/dev/null || break; sleep 0.02; done
    kill -KILL "$p" 2>/dev/null
  done
  for n in "${ns[@]}"; do ip netns del "$n" 2>/dev/null; done
  ip link del "$br" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

[ "$(id -u)" -eq 0 ] || skip "network namespaces need root (uid $(id -u))"
command -v ip >/dev/null || skip "no 'ip' command (iproute2)"
ip netns add "${ns[0]}" 2>"$work/err" || skip "cannot create a network namespace: $(cat "$work/err")"
ip netns add "${ns[1]}" && ip netns add "${ns[2]}" || fail "ip netns add"
ip link add "$br" type bridge || skip "cannot create a bridge: $(ip link add "$br" type bridge 2>&1)"
ip addr add 10.213.0.1/24 dev "$br" && ip link set "$br" up || fail "bridge address"
for i in 0 1 2; do
  v="${tag}v$i"
  ip link add "$v" type veth peer name "${v}p" || fail "veth"
  ip link set "${v}p" netns "${ns[$i]}" || fail "veth into ${ns[$i]}"
  ip link set "$v" master "$br" && ip link set "$v" up || fail "veth on bridge"
  ip -n "${ns[$i]}" addr add "${addrs[$i]}/24" dev "${v}p" || fail "address in ${ns[$i]}"
  ip -n "${ns[$i]}" link set "${v}p" up && ip -n "${ns[$i]}" link set lo up || fail "links up in ${ns[$i]}"
done

# a fresh cluster key, one daemon per namespace, peers of each other
key="$work/key"
(umask 077; od -An -tx1 -N32 /dev/urandom | tr -d ' \n' > "$key")
hosts="$work/hosts"
: > "$hosts"
for i in 0 1 2; do echo "${names[$i]} ${addrs[$i]}:7411" >> "$hosts"; done
for i in 0 1 2; do
  peers=()
  for j in 0 1 2; do [ "$j" -ne "$i" ] && peers+=(--peer "${addrs[$j]}:7411"); done
  ip netns exec "${ns[$i]}" "$dca" daemon --host "${names[$i]}" --listen "${addrs[$i]}:7411" "${peers[@]}" \
    --key "$key" >"$work/${names[$i]}.log" 2>&1 &
  pids+=($!)
done
for i in 0 1 2; do
  for _ in $(seq 1 500); do grep -q "listening on" "$work/${names[$i]}.log" && break; sleep 0.01; done
  grep -q "listening on" "$work/${names[$i]}.log" || fail "daemon ${names[$i]}: $(cat "$work/${names[$i]}.log")"
done
echo "three daemons up: $(tr '\n' ' ' < "$hosts")"

# the system: Counter (vision) -> Threshold at 300 (manip), Constant (platform) -> Gain (manip); about 3 s
sys="$work/netns_chain.dca"
sed -e 's/Threshold(h, 30)/Threshold(h, 300)/' "$src/scripts/systems/test_three_hosts.dca" > "$sys"
DCA_KEY_FILE="$key" "$dca" run "$sys" --hosts "$hosts" > "$work/run.out" 2>&1 &
run_pid=$!

# while it runs: the Threshold's node (on manip) must have an established TCP connection from vision's
# address to one of its own listening ports: the data connection from the Counter, host to host
direct=""
for _ in $(seq 1 300); do
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
