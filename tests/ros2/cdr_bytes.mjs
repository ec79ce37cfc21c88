// The independent side of ros2.cdr_bytes_rosmsg2_serialization: for every DIR/<pkg>.msg.<T>.json that
// ros2_msgs_samples wrote, @foxglove/rosmsg2-serialization's MessageWriter encodes the JSON from the
// @foxglove/rosmsg-msgs-common ROS 2 Jazzy definitions: the bytes must equal dca's DIR/<pkg>.msg.<T>.cdr; its
// MessageReader decodes dca's bytes: the values must equal the JSON. dca's ros2msg definition
// (DIR/<pkg>.msg.<T>.msg, the schema of the MCAP ros2 profile) parsed by @foxglove/rosmsg must give the same
// fields as @foxglove/rosmsg-msgs-common's, and decode dca's bytes to the same values. Writes
// DIR/<pkg>.msg.<T>.node.cdr for ros2_msgs_samples read.
import { readdirSync, readFileSync, writeFileSync } from "node:fs";
import { createRequire } from "node:module";
import { isDeepStrictEqual } from "node:util";

const require = createRequire(import.meta.url);
let common, serialization, rosmsg;
try {
  common = require("@foxglove/rosmsg-msgs-common");
  serialization = require("@foxglove/rosmsg2-serialization");
  rosmsg = require("@foxglove/rosmsg");
} catch (e) {
  console.error(`tests/ros2/node_modules is incomplete (${e.message}): scripts/setup installs it (npm ci)`);
  process.exit(1);
}
const { ros2jazzy } = common;
const { MessageReader, MessageWriter } = serialization;

const dir = process.argv[2];

// A definition's fields as the check compares them: "pkg/msg/T" and ROS 2's "time" named as "pkg/T", default values
// only where dca's text gives one (the common definitions give "float64 x 0" where dca writes "float64 x").
const norm = (t) => (t === "time" ? "builtin_interfaces/Time" : t.replace("/msg/", "/"));
const fields = (def, defaults) =>
  def.definitions.map((f) => ({
    name: f.name, type: norm(f.type), isArray: !!f.isArray, arrayLength: f.arrayLength, isComplex: !!f.isComplex,
    ...(defaults[f.name] !== undefined ? { d: f.defaultValue } : {}),
  }));
const plainOf = (v) => JSON.parse(JSON.stringify(v, (k, x) => (ArrayBuffer.isView(x) ? Array.from(x) : x)));

// 1 when dca's ros2msg text of `name` does not parse to the common definitions, or does not decode `cdr` to `want`.
function checkDefinition(name, text, cdr, want) {
  const parsed = rosmsg.parse(text, { ros2: true });
  let bad = 0;
  for (const [i, def] of parsed.entries()) {
    const key = i === 0 ? name : norm(def.name);
    const ours = Object.fromEntries(def.definitions.map((f) => [f.name, f.defaultValue]));
    if (!isDeepStrictEqual(fields(def, ours), fields(ros2jazzy[key], ours))) {
      console.log(`${name}: dca's definition of ${key} differs:`);
      console.log(`  ${JSON.stringify(def)}\n  ${JSON.stringify(ros2jazzy[key])}`);
      bad = 1;
    }
  }
  const decoded = new MessageReader(parsed).readMessage(cdr);
  if (!isDeepStrictEqual(plainOf(decoded), want)) {
    console.log(`${name}: dca's bytes decode otherwise with dca's ros2msg definition`);
    bad = 1;
  }
  return bad;
}
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
  const plain = plainOf(decoded);
  if (!isDeepStrictEqual(plain, value)) {
    console.log(`${name}: dca's bytes decode to ${JSON.stringify(plain)}\n  expected ${JSON.stringify(value)}`);
    failed++;
  }
  failed += checkDefinition(name, readFileSync(`${dir}/${base}.msg`, "utf8"), dca, plain);
  if (same) console.log(`${name}: ${dca.length} bytes, the same on both sides; its ros2msg definition checked`);
  checked++;
}
if (checked < 20) {
  console.log(`only ${checked} message types checked (20 expected)`);
  failed++;
}
process.exit(failed ? 1 : 0);
