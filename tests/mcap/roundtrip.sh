#!/bin/sh
# MCAP round trip (issue 19): a short door run of the world (`dca sim`, the scripted door opening, 3 simulated
# seconds) recorded to MCAP is read back by an independent reader, @mcap/core (read_mcap.mjs: every channel
# has a JSON Schema, the summary, summary offsets and chunk indexes are present, the message counts match
# the ones dca printed, every record streams with valid CRCs), and `dca plot` draws it to a PNG.
#   roundtrip.sh DCA WORK_DIR
set -eu
dca=$1
work=$2
here=$(cd "$(dirname "$0")" && pwd)
if [ ! -d "$here/node_modules/@mcap/core" ]; then
  echo "tests/mcap/node_modules/@mcap/core is missing: scripts/setup installs it (npm ci)" >&2
  exit 1
fi
mkdir -p "$work"
rm -f "$work/door.mcap" "$work/door.png"
out=$("$dca" sim --duration 3 --record "$work/door.mcap")
echo "$out"
line=$(echo "$out" | grep '^recorded ')
node "$here/read_mcap.mjs" "$work/door.mcap" "$line"
"$dca" plot "$work/door.mcap" -o "$work/door.png"
if [ "$(od -An -tx1 -N4 "$work/door.png" | tr -d ' ')" != "89504e47" ]; then
  echo "dca plot did not write a PNG: $work/door.png" >&2
  exit 1
fi
echo "drew $work/door.png ($(wc -c < "$work/door.png") bytes)"
