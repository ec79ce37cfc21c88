# The fleet of netns.fleet (tests/netns/fleet.sh) and its benchmark (tests/bench/fleet_netns_bench.sh), after
# lib.sh with the names base door r1..r8:
#   fleet_up PORT [ARG...]   the daemons on the simulated clock (each its state folder), the system written (the door
#                            system's processes, scripts/systems/door_open.dca up to its main, then the fleet's main)
#                            and run with `dca run --sim door --realtime --world-host door [ARG...]`; returns once
#                            the door robot's arm controller runs, with run_pid, root (the console's address) set
# and said PATTERN (the run's output has it), said_or_ended PATTERN, repl LINE... (through `dca repl`).
said() { grep -q -- "$1" "$work/run.out"; }
said_or_ended() { said "$1" || ! kill -0 "$run_pid" 2>/dev/null; }
repl() { printf '%s\n' "$@" | "$dca" repl main --daemon "$root" --key "$key" 2>&1; }

fleet_up() {
  local port=$1; shift
  daemons_up "$port" --clock sim --state-dir "$work/state/{host}"
  sys="$work/fleet.dca"
  {
    sed '/^process main()/,$d' "$src/scripts/systems/door_open.dca"
    cat <<'DCA'
process Robot(h, period) {
  instantiated_processes { light instof Counter(h, period); }
  internal_event_actions { light }
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
  DCA_KEY_FILE="$key" "$dca" run "$sys" --hosts "$hosts" --sim door --realtime --world-host door "$@" \
    > "$work/run.out" 2>&1 &
  run_pid=$!
  wait_for said_or_ended "main.door.motionctrl.puma: running"
  said "main.door.motionctrl.puma: running" || { cat "$work/run.out"; fail "the door robot never ran"; }
  root=$(grep -o "console: dca repl main --daemon [^ ]*" "$work/run.out" | awk '{print $NF}')
  [ -n "$root" ] || { cat "$work/run.out"; fail "no console address"; }
}
