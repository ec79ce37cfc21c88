# Shared by the tests/netns/*.sh tests: network namespaces on a bridge (three, or one per NAME given), one dca
# daemon in each.
#   . lib.sh DCA_EXE TAG SUBNET NAME NAME NAME [NAME...]
# DCA_EXE may be empty ($DCA_EXE, else dca on the PATH); TAG is unique and short; SUBNET is e.g. 10.213.0 (the
# bridge is .1, the hosts .2 .3 .4 ...; at most 12 names). It sets dca, src (the source tree), names, ns, addrs, br, work, key, pids,
# hosts (the hosts file daemons_up writes), installs the cleanup trap and defines skip/fail and wait_for. Needs root:
# without it, skip (exit 77, CTest's skipped).
dca="${1:-${DCA_EXE:-dca}}"
tag=$2
subnet=$3
names=("${@:4}")
src="${DCA_SOURCE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
ns=() addrs=()
letters=(a b c d e f g h i j k l)
for i in "${!names[@]}"; do ns+=("${tag}${letters[$i]}"); addrs+=("$subnet.$((i + 2))"); done
br="${tag}br"
work="$(mktemp -d)"
key="$work/key"
hosts="$work/hosts"
pids=()

skip() { echo "SKIP: $*"; exit 77; }
# Fails naming why, with the end of each daemon's log.
fail() {
  echo "FAIL: $*"
  for n in "${names[@]}"; do echo "--- daemon $n:"; tail -20 "$work/$n.log" 2>/dev/null; done
  exit 1
}

# Stops the daemons (TERM, then KILL after 2 s); pids is empty after it.
daemons_down() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do
    for _ in $(seq 1 100); do kill -0 "$p" 2>/dev/null || break; sleep 0.02; done
    kill -KILL "$p" 2>/dev/null
  done
  pids=()
}

# Stops the daemons and removes the namespaces, the bridge and the work dir.
cleanup() {
  daemons_down
  for n in "${ns[@]}"; do ip netns del "$n" 2>/dev/null; done
  ip link del "$br" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

# Makes the namespaces, each with a veth on the bridge and its address, and a fresh cluster key.
netns_up() {
  [ "$(id -u)" -eq 0 ] || skip "network namespaces need root (uid $(id -u))"
  command -v ip >/dev/null || skip "no 'ip' command (iproute2)"
  ip netns add "${ns[0]}" 2>"$work/err" || skip "cannot create a network namespace: $(cat "$work/err")"
  local i v
  for i in "${!ns[@]}"; do [ "$i" -eq 0 ] || ip netns add "${ns[$i]}" || fail "ip netns add"; done
  ip link add "$br" type bridge || skip "cannot create a bridge: $(ip link add "$br" type bridge 2>&1)"
  ip addr add "$subnet.1/24" dev "$br" && ip link set "$br" up || fail "bridge address"
  for i in "${!ns[@]}"; do
    v="${tag}v$i"
    ip link add "$v" type veth peer name "${v}p" || fail "veth"
    ip link set "${v}p" netns "${ns[$i]}" || fail "veth into ${ns[$i]}"
    ip link set "$v" master "$br" && ip link set "$v" up || fail "veth on bridge"
    ip -n "${ns[$i]}" addr add "${addrs[$i]}/24" dev "${v}p" || fail "address in ${ns[$i]}"
    ip -n "${ns[$i]}" link set "${v}p" up && ip -n "${ns[$i]}" link set lo up || fail "links up in ${ns[$i]}"
  done
  (umask 077; od -An -tx1 -N32 /dev/urandom | tr -d ' \n' > "$key")
}

# `daemons_up PORT [ARG...]`: a daemon in each namespace listening on its address:PORT, the others as peers,
# with ARGs (where "{host}" stands for the daemon's host name); returns when all listen. The hosts file
# $hosts (for `dca run --hosts`) names each daemon's address.
daemons_up() {
  local port=$1 i j n; shift
  : > "$hosts"
  for i in "${!names[@]}"; do echo "${names[$i]} ${addrs[$i]}:$port" >> "$hosts"; done
  for i in "${!names[@]}"; do
    local peers=() args=()
    for j in "${!names[@]}"; do [ "$j" -ne "$i" ] && peers+=(--peer "${addrs[$j]}:$port"); done
    for a in "$@"; do args+=("${a//\{host\}/${names[$i]}}"); done
    ip netns exec "${ns[$i]}" "$dca" daemon --host "${names[$i]}" --listen "${addrs[$i]}:$port" "${peers[@]}" \
      --key "$key" "${args[@]}" >"$work/${names[$i]}.log" 2>&1 &
    pids+=($!)
  done
  wait_listening
}

# `wait_for CMD [ARG...]`: returns 0 as soon as CMD succeeds (polled every 20 ms), 1 once $wait_s seconds went by
# without (default 60: a start on a loaded 2-core machine, or under ASan, takes seconds; the bound is for a hang,
# not for how fast it goes). Never a fixed sleep: the caller says what it waited for.
wait_s="${DCA_NETNS_WAIT:-60}"
wait_for() {
  local deadline=$((SECONDS + wait_s))
  until "$@"; do
    [ "$SECONDS" -lt "$deadline" ] || return 1
    sleep 0.02
  done
}

# Returns when each daemon (its log $work/NAME.log) has said it listens (wait_for each); else fails.
wait_listening() {
  local n
  for n in "${names[@]}"; do
    wait_for grep -q "listening on" "$work/$n.log" || fail "daemon $n did not start within ${wait_s} s"
  done
}
