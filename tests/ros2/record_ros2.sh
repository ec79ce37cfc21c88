#!/bin/sh
# The MCAP `ros2` profile (docs/recording.md, "The ros2 profile"), read back by independent readers and by dca:
#   record_ros2.sh DCA SOURCE_DIR WORK_DIR
# 1. `dca run systems/joint_states_record.dca --sim mock:worlds/ur10/ur10.urdf --record ros2.mcap --record-ports
#    all --profile ros2` ends DONE; read_ros2_mcap.mjs reads the file with @mcap/core: header profile "ros2", the
#    JointState port's channel CDR with a ros2msg schema, each message decoded by @foxglove/rosmsg2-serialization
#    from the definition the schema holds (parsed by @foxglove/rosmsg), the other channels JSON.
# 2. `dca plot --list ros2.mcap` lists the message's fields (position[0], header.stamp.sec, ...).
# 3. The same run recorded without the profile (json.mcap): `dca trace diff ros2.mcap json.mcap` finds them
#    identical, the CDR channel read back as the JSON one's messages.
# 4. A round trip: the run replayed from ros2.mcap (`--replay ros2.mcap`, the replay reading the profile) and
#    recorded with the profile again (replay.mcap): read_ros2_mcap.mjs checks it and finds its JointState messages
#    the bytes of ros2.mcap's at the same log times.
set -eu
dca=$1
src=$2
work=$3
here=$(cd "$(dirname "$0")" && pwd)
for m in "$src/tests/mcap/node_modules/@mcap/core" "$here/node_modules/@foxglove/rosmsg2-serialization"; do
  if [ ! -d "$m" ]; then
    echo "$m is missing: scripts/setup installs it (npm ci)" >&2
    exit 1
  fi
done
rm -rf "$work"
mkdir -p "$work"
sys="$here/systems/joint_states_record.dca"
world="mock:$src/worlds/ur10/ur10.urdf"
if ! "$dca" run "$sys" --sim "$world" --record "$work/ros2.mcap" --record-ports all --profile ros2 \
    >"$work/ros2.log" 2>&1; then
  tail -40 "$work/ros2.log"
  echo "FAIL: dca run --record ros2.mcap --profile ros2 did not end DONE" >&2
  exit 1
fi
grep '^recorded ' "$work/ros2.log" | cut -c1-200
node "$here/read_ros2_mcap.mjs" "$work/ros2.mcap" \
  /main/states/JointState "shoulder_pan_joint shoulder_lift_joint elbow_joint" base_link
"$dca" plot --list "$work/ros2.mcap" >"$work/list.txt"
for field in 'JointState.position\[0\]' 'JointState.position\[2\]' 'JointState.velocity\[1\]' \
    'JointState.header.stamp.sec' 'JointState.header.stamp.nanosec'; do
  if ! grep -q "^/main/states/$field  [1-9][0-9]* samples" "$work/list.txt"; then
    cat "$work/list.txt"
    echo "FAIL: dca plot --list shows no /main/states/$field" >&2
    exit 1
  fi
done
echo "dca plot --list: the JointState's fields listed"
if ! "$dca" run "$sys" --sim "$world" --record "$work/json.mcap" --record-ports all >"$work/json.log" 2>&1; then
  tail -40 "$work/json.log"
  echo "FAIL: dca run --record json.mcap did not end DONE" >&2
  exit 1
fi
"$dca" trace diff "$work/ros2.mcap" "$work/json.mcap" >"$work/diff.txt" 2>&1 || true
cat "$work/diff.txt"
grep -q '^identical: ' "$work/diff.txt" || { echo "FAIL: the two profiles' recordings differ" >&2; exit 1; }
if ! "$dca" run "$sys" --replay "$work/ros2.mcap" --record "$work/replay.mcap" --record-ports all --profile ros2 \
    >"$work/replay.log" 2>&1; then
  tail -40 "$work/replay.log"
  echo "FAIL: the replay of ros2.mcap did not end DONE" >&2
  exit 1
fi
node "$here/read_ros2_mcap.mjs" "$work/replay.mcap" /main/states/JointState \
  "shoulder_pan_joint shoulder_lift_joint elbow_joint" base_link "$work/ros2.mcap"
rm -rf "$work"
