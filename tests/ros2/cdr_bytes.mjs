// The independent side of ros2.cdr_bytes_rosmsg2_serialization: for every DIR/<pkg>.msg.<T>.json that
// ros2_msgs_samples wrote, @foxglove/rosmsg2-serialization's MessageWriter encodes the JSON from the
// @foxglove/rosmsg-msgs-common ROS 2 Jazzy definitions: the bytes must equal dca's DIR/<pkg>.msg.<T>.cdr; its
// MessageReader decodes dca's bytes: the values must equal the JSON. Writes DIR/<pkg>.msg.<T>.node.cdr for
// ros2_msgs_samples read.
import { readdirSync, readFileSync, writeFileSync } from "node:fs";
import { createRequire } from "node:module";
import { isDeepStrictEqual } from "node:util";

const require = createRequire(import.meta.url);
let common, serialization;
try {
  common = require("@foxglove/rosmsg-msgs-common");
  serialization = require("@foxglove/rosmsg2-serialization");
} catch (e) {
  console.error(`tests/ros2/node_modules is incomplete (${e.message}): scripts/setup installs it (npm ci)`);
  process.exit(1);
}
const { ros2jazzy } = common;
const { MessageReader, MessageWriter } = serialization;

const dir = process.argv[2];
const all = Object.values(ros2jazzy);
let failed = 0;
let checked = 0;
for (const f of readdirSync(dir).filter((f) => f.endsWith(".json")).sort()) {
  const base = f.slice(0, -".json".length);
  const [pkg, , type] = base.split(".");
  const name = `${pkg}/${type}`;
  const root = ros2jazzy[name];
  if (!root) {
    console.log(`${name}: no definition in @foxglove/rosmsg-msgs-common`);
    failed++;
    continue;
  }
  const defs = [root, ...all.filter((d) => d !== root)];
  const value = JSON.parse(readFileSync(`${dir}/${f}`, "utf8"));
  const dca = new Uint8Array(readFileSync(`${dir}/${base}.cdr`));
  const node = new MessageWriter(defs).writeMessage(value);
  writeFileSync(`${dir}/${base}.node.cdr`, node);
  const decoded = new MessageReader(defs).readMessage(dca);
  const same = node.length === dca.length && node.every((b, i) => b === dca[i]);
  const hex = (a) => Buffer.from(a).toString("hex");
  if (!same) {
    console.log(`${name}: bytes differ\n  dca  ${hex(dca)}\n  node ${hex(node)}`);
    failed++;
  }
  // typed arrays (float64[] and float64[36] decode to Float64Array) compared as plain arrays
  const plain = JSON.parse(JSON.stringify(decoded, (k, v) => (ArrayBuffer.isView(v) ? Array.from(v) : v)));
  if (!isDeepStrictEqual(plain, value)) {
    console.log(`${name}: dca's bytes decode to ${JSON.stringify(plain)}\n  expected ${JSON.stringify(value)}`);
    failed++;
  }
  if (same) console.log(`${name}: ${dca.length} bytes, the same on both sides`);
  checked++;
}
if (checked < 20) {
  console.log(`only ${checked} message types checked (20 expected)`);
  failed++;
}
process.exit(failed ? 1 : 0);
