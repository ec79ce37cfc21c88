# The fleet of netns.fleet (tests/netns/fleet.sh) and its benchmark (tests/bench/fleet_netns_bench.sh), after
# lib.sh with the names base door r1..r8:
#   fleet_up PORT [ARG...]   the daemons on the simulated clock (each its state folder: its package store), the
#                            system written (the door system's processes, scripts/systems/door_open.dca up to its
#                            main, then the fleet's; the test package pkg_ok in packages/ beside it)
#                            and run with `dca run --sim door --realtime --world-host door [ARG...]`; returns once
#                            the door robot's arm controller runs, with run_pid, root (the console's address) set
# and said PATTERN (the run's output has it), said_or_ended PATTERN, repl LINE... (through `dca repl`), pk (the
# test packages' folder, $DCA_TEST_PACKAGES_DIR: pkg_ok and its rebuilds variants/crash, variants/k3),
# upgrade DIR WATCH (`dca upgrade` of DIR's pkg_ok, canary r1, watched WATCH s).
pk="${DCA_TEST_PACKAGES_DIR:?DCA_TEST_PACKAGES_DIR is not set (the test packages: tests/packages)}"
said() { grep -q -- "$1" "$work/run.out"; }
said_or_ended() { said "$1" || ! kill -0 "$run_pid" 2>/dev/null; }
repl() { printf '%s\n' "$@" | "$dca" repl main --daemon "$root" --key "$key" 2>&1; }
upgrade() { "$dca" upgrade "$1" --system main --daemon "$root" --key "$key" --canary r1 --watch "$2" 2>&1; }

fleet_up() {
  local port=$1; shift
  daemons_up "$port" --clock sim --state-dir "$work/state/{host}"
  sys="$work/fleet.dca"
  {
    echo "use pkg_ok;"
    sed '/^process main()/,$d' "$src/scripts/systems/door_open.dca"
    cat <<'DCA'
// a light robot: its Counter through PkgScale (the test package pkg_ok, rolled by `dca upgrade`), restarted
// one_for_one (an ABORTED too: a live restart whose new process dies before it runs ends its leaf so)
process Robot(h, period) {
  supervision { strategy one_for_one; intensity 3 in 60 s; restart on crash, lost, aborted; }
  instantiated_processes {
    light instof Counter(h, period);
    scale instof PkgScale(h);
  }
  internal_connections(light, run) { light, Count -> scale, In; }
  internal_event_actions { light[run], scale }
}
process main() {
  host { "base" }
  supervision { strategy one_for_one; intensity 5 in 10 s; restart on crash, lost; }
  instantiated_processes {
    door instof DoorOpenSystem("door", "door", "door");
    heartbeat instof Counter("base", 1);   // the fleet runs on once the door is open
    lights instances of Robot(0.05) on { "r1", "r2", "r3", "r4", "r5", "r6", "r7", "r8" };
  }
  internal_event_actions { door , heartbeat }
}
DCA
  } > "$sys"
  cp "$src/scripts/systems/door_open.config" "$work/fleet.config"
  mkdir -p "$work/packages" && cp "$pk/pkg_ok.dca.so" "$work/packages/" || fail "the system's packages folder"
  # (one process per leaf: the test finds each leaf's process and namespace, and `dca upgrade` restarts leaves
  # onto new code, which a shared node cannot load; simulated time places as `host` otherwise)
  DCA_KEY_FILE="$key" "$dca" run "$sys" --hosts "$hosts" --sim door --realtime --world-host door \
    --placement process "$@" \
    > "$work/run.out" 2>&1 &
  run_pid=$!
  wait_for said_or_ended "main.door.motionctrl.puma: running"
  said "main.door.motionctrl.puma: running" || { cat "$work/run.out"; fail "the door robot never ran"; }
  root=$(grep -o "console: dca repl main --daemon [^ ]*" "$work/run.out" | awk '{print $NF}')
  [ -n "$root" ] || { cat "$work/run.out"; fail "no console address"; }
}
