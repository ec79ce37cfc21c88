#!/bin/sh
# MCAP round trips, read back by an independent reader, @mcap/core (read_mcap.mjs), and drawn by
# `dca plot` to a PNG:
#   roundtrip.sh sim DCA SOURCE_DIR WORK_DIR   a short door run of the world (`dca sim`, the scripted door
#       opening, 3 simulated seconds): every channel has a JSON Schema, the summary, summary offsets and chunk
#       indexes are present, the message counts match the ones dca printed, every record streams with valid CRCs
#   roundtrip.sh run DCA SOURCE_DIR WORK_DIR   a supervised door run (`dca run door_open.dca --sim door`) ends
#       DONE, and beside the world's signals /dca/events holds every line the run printed ("[sim T] path:
#       state", the transitions among them) at its simulated time
#   roundtrip.sh ports DCA SOURCE_DIR WORK_DIR [PLACEMENT]   the supervised door run with --record-ports all
#       --trace (and --placement PLACEMENT: leaves in shared nodes are tapped alike): every port's channel holds
#       its samples at the ticks the trace gives (read_mcap.mjs --trace), and the trace is identical to the one
#       of the same run without taps or recording, one leaf per process (`dca trace diff`)
#   roundtrip.sh urdf DCA SOURCE_DIR WORK_DIR   the UR10 system on the URDF world (`dca run ur10_setpoint.dca
#       --sim worlds/ur10/ur10.urdf --record --record-ports all`): the checks of `sim`, then read_robot.mjs: the
#       URDF on /robot_description, a foxglove.FrameTransforms of every link per tick, agreeing with the joints
#   roundtrip.sh wall DCA SOURCE_DIR WORK_DIR   a wall-clock run against a driver with a leaf on a real-time thread
#       (tests/lua/launch/systems/rt_loop.dca --driver 'Gain("h1", 2)' --record): the checks of `sim`, then the
#       leaf's figures on /dca/rt/main/loop/n, each fitting its channel's JSON Schema (read_mcap.mjs --rt)
#   roundtrip.sh compressed DCA SOURCE_DIR WORK_DIR   `dca sim --record` with --record-compression lz4 and none
#       (zstd is the default, read in every other mode): the checks of `sim`, each chunk compressed so, decompressed
#       by fzstd and lz4js; then --record-split 1s: FILE-000.mcap ... each a whole recording with every channel,
#       holding its second of messages (read_split.mjs)
set -eu
mode=$1
dca=$2
src=$3
work=$4
here=$(cd "$(dirname "$0")" && pwd)
if [ ! -d "$here/node_modules/@mcap/core" ]; then
  echo "tests/mcap/node_modules/@mcap/core is missing: scripts/setup installs it (npm ci)" >&2
  exit 1
fi
mkdir -p "$work"
rm -f "$work/door.mcap" "$work/door.png" "$work/door.log"
if [ "$mode" = urdf ]; then
  rm -f "$work/ur10.mcap"
  if ! "$dca" run "$src/worlds/ur10/ur10_setpoint.dca" --sim "$src/worlds/ur10/ur10.urdf" --record "$work/ur10.mcap" \
      --record-ports all >"$work/ur10.log" 2>&1; then
    tail -40 "$work/ur10.log"
    echo "FAIL: dca run --sim ur10.urdf --record did not end DONE" >&2
    exit 1
  fi
  grep '^recorded ' "$work/ur10.log" | cut -c1-200
  node "$here/read_mcap.mjs" "$work/ur10.mcap" "$(grep '^recorded ' "$work/ur10.log" | sed 's/^recorded //')"
  exec node "$here/read_robot.mjs" "$work/ur10.mcap" "$src/worlds/ur10/ur10.urdf"
fi
if [ "$mode" = wall ]; then
  if ! "$dca" run "$src/tests/lua/launch/systems/rt_loop.dca" --driver 'Gain("h1", 2)' --record "$work/door.mcap" \
      >"$work/door.log" 2>&1; then
    tail -40 "$work/door.log"
    echo "FAIL: the wall-clock run with --record did not end DONE" >&2
    exit 1
  fi
  grep '^recorded ' "$work/door.log" | cut -c1-200
  node "$here/read_mcap.mjs" "$work/door.mcap" "$(grep '^recorded ' "$work/door.log" | sed 's/^recorded //')" \
    --rt main.loop.n
  rm -f "$work/door.mcap" "$work/door.log"
  exit 0
fi
if [ "$mode" = compressed ]; then
  for c in lz4 none; do
    rm -f "$work/door-$c.mcap"
    "$dca" sim --duration 3 --record "$work/door-$c.mcap" --record-compression "$c" >"$work/door-$c.log"
    grep '^recorded ' "$work/door-$c.log" | cut -c1-200
    node "$here/read_mcap.mjs" "$work/door-$c.mcap" "$(grep '^recorded ' "$work/door-$c.log")"
    node "$here/read_mcap.mjs" "$work/door-$c.mcap" --compression "$c"
  done
  rm -f "$work"/split*.mcap
  "$dca" sim --duration 3 --record "$work/split.mcap" --record-split 1s >"$work/split.log"
  grep '^recorded ' "$work/split.log" | cut -c1-200
  if [ -e "$work/split.mcap" ]; then echo "FAIL: split.mcap itself was written" >&2; exit 1; fi
  exec node "$here/read_split.mjs" 1 "$(grep '^recorded ' "$work/split.log")" "$work"/split-0*.mcap
fi
if [ "$mode" = ports ]; then
  system="$src/worlds/door/systems/door_open.dca"
  if ! "$dca" run "$system" --sim door --placement "${5:-process}" --record "$work/door.mcap" --record-ports all \
      --trace "$work/taps.trace" >"$work/door.log" 2>&1; then
    tail -40 "$work/door.log"
    echo "FAIL: dca run --record-ports all did not end DONE" >&2
    exit 1
  fi
  # the same run without taps has the same trace (DCA_SANITIZED=1: left out, simulated time is the optimised
  # build's to show)
  if [ "${DCA_SANITIZED:-0}" != 1 ]; then
    if ! "$dca" run "$system" --sim door --trace "$work/plain.trace" >"$work/plain.log" 2>&1; then
      tail -40 "$work/plain.log"
      echo "FAIL: dca run without taps did not end DONE" >&2
      exit 1
    fi
    "$dca" trace diff "$work/taps.trace" "$work/plain.trace"
  fi
  grep '^recorded ' "$work/door.log"
  node "$here/read_mcap.mjs" "$work/door.mcap" "$(grep '^recorded ' "$work/door.log" | sed 's/^recorded //')" \
    --trace "$work/taps.trace"
elif [ "$mode" = sim ]; then
  "$dca" sim --duration 3 --record "$work/door.mcap" | tee "$work/door.log"
  node "$here/read_mcap.mjs" "$work/door.mcap" "$(grep '^recorded ' "$work/door.log")"
else
  if ! "$dca" run "$src/worlds/door/systems/door_open.dca" --sim door --record "$work/door.mcap" >"$work/door.log" 2>&1
  then
    tail -40 "$work/door.log"
    echo "FAIL: dca run did not end DONE" >&2
    exit 1
  fi
  grep '^\[sim ' "$work/door.log" | tail -5
  node "$here/read_mcap.mjs" "$work/door.mcap" --lines "$work/door.log"
fi
"$dca" plot "$work/door.mcap" -o "$work/door.png"
if [ "$(od -An -tx1 -N4 "$work/door.png" | tr -d ' ')" != "89504e47" ]; then
  echo "dca plot did not write a PNG: $work/door.png" >&2
  exit 1
fi
echo "drew $work/door.png ($(wc -c < "$work/door.png") bytes)"
