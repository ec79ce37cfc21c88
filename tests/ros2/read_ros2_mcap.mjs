// The independent side of ros2.record_profile_mcap_core (record_ros2.sh): a recording of `dca run ... --profile
// ros2` read by @mcap/core (tests/mcap's, pinned there) and its ROS 2 messages decoded by
// @foxglove/rosmsg2-serialization from the definitions their schemas hold (parsed by @foxglove/rosmsg):
//   node read_ros2_mcap.mjs FILE.mcap TOPIC "JOINT JOINT ..." FRAME [SAME.mcap]
// Checks: the header's profile is "ros2"; TOPIC's channel is CDR, its schema ros2msg named
// sensor_msgs/msg/JointState, with the offered_qos_profiles the profile requires; every message on it decodes (no
// byte left but DDS's padding) to a JointState of those joints, that frame, positions and velocities one per
// joint, its stamp the message's log time; every other channel is JSON with a JSON Schema. With SAME.mcap: TOPIC's
// messages there are the same bytes at the same log times. Exit 1 on a mismatch.
import { createRequire } from "node:module";

const [file, topic, joints, frame, same] = process.argv.slice(2);
if (!frame) {
  console.error("usage: node read_ros2_mcap.mjs FILE.mcap TOPIC JOINTS FRAME");
  process.exit(2);
}
const here = new URL(".", import.meta.url);
let MessageReader, parse, openIndexed;
try {
  ({ openIndexed } = await import(new URL("../mcap/decompress.mjs", here)));  // @mcap/core's indexed reader
  const require = createRequire(import.meta.url);
  ({ MessageReader } = require("@foxglove/rosmsg2-serialization"));
  ({ parse } = require("@foxglove/rosmsg"));
} catch (e) {
  console.error(`tests/mcap or tests/ros2 node_modules incomplete (${e.message}): scripts/setup installs them (npm ci)`);
  process.exit(1);
}
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

const openReader = async (path) => (await openIndexed(path)).reader;
// TOPIC's messages in `r`: [{t, hex}]
async function messagesOf(r) {
  const id = [...r.channelsById].find(([, c]) => c.topic === topic)?.[0];
  const out = [];
  for await (const m of r.readMessages({ validateCrcs: true })) {
    if (m.channelId === id) out.push({ t: m.logTime, hex: Buffer.from(m.data).toString("hex") });
  }
  return out;
}
const reader = await openReader(file);
check(reader.header.profile === "ros2", `header profile '${reader.header.profile}', not ros2`);

const decoders = new Map();  // channel id -> MessageReader
let target;
for (const [id, ch] of reader.channelsById) {
  const schema = reader.schemasById.get(ch.schemaId);
  const text = new TextDecoder().decode(schema.data);
  if (ch.topic === topic) {
    target = id;
    check(ch.messageEncoding === "cdr", `${topic}: message encoding ${ch.messageEncoding}`);
    check(schema.encoding === "ros2msg", `${topic}: schema encoding ${schema.encoding}`);
    check(schema.name === "sensor_msgs/msg/JointState", `${topic}: schema ${schema.name}`);
    check((ch.metadata.get("offered_qos_profiles") ?? "").includes("reliability: 1"),
          `${topic}: no offered_qos_profiles of ROS 2's default QoS`);
    check(text.includes("\nMSG: std_msgs/Header\n"), `${topic}: the definition lacks std_msgs/Header`);
    try {
      if (schema.encoding === "ros2msg") decoders.set(id, new MessageReader(parse(text, { ros2: true })));
    } catch (e) {
      check(false, `${topic}: the schema does not parse as a ROS 2 definition: ${e.message}`);
    }
  } else {
    check(ch.messageEncoding === "json" && schema.encoding === "jsonschema",
          `${ch.topic}: ${ch.messageEncoding} with ${schema.encoding}, not JSON`);
    JSON.parse(text);
  }
}
check(target !== undefined, `no channel ${topic}`);

const names = joints.split(" ");
let n = 0, json = 0, lastStamp = -1n;
for await (const msg of reader.readMessages({ validateCrcs: true })) {
  const dec = decoders.get(msg.channelId);
  if (!dec) {
    JSON.parse(new TextDecoder().decode(msg.data));
    json++;
    continue;
  }
  n++;
  let m;
  try {
    m = dec.readMessage(msg.data);
  } catch (e) {
    check(false, `${topic}: message ${n} does not decode: ${e.message}`);
    continue;
  }
  const stamp = BigInt(m.header.stamp.sec) * 1000000000n + BigInt(m.header.stamp.nanosec);
  check(m.header.frame_id === frame, `${topic}: frame_id '${m.header.frame_id}'`);
  check(JSON.stringify(m.name) === JSON.stringify(names), `${topic}: names ${JSON.stringify(m.name)}`);
  check(m.position.length === names.length && m.velocity.length === names.length,
        `${topic}: ${m.position.length} positions, ${m.velocity.length} velocities`);
  check([...m.position, ...m.velocity].every(Number.isFinite), `${topic}: a value not finite`);
  check(stamp === msg.logTime, `${topic}: stamp ${stamp} ns at log time ${msg.logTime}`);
  check(stamp > lastStamp, `${topic}: stamps not increasing`);
  lastStamp = stamp;
  if (n === 1) console.log(`first ${topic}: ${JSON.stringify({ ...m, position: [...m.position], velocity: [...m.velocity], effort: [...m.effort] })}`);
}
check(n >= 10, `${topic}: ${n} messages, fewer than 10`);
console.log(`${file}: profile "${reader.header.profile}", ${n} JointState messages decoded from CDR, ${json} JSON messages`);
if (same) {
  const a = await messagesOf(reader), b = await messagesOf(await openReader(same));
  check(a.length === b.length, `${topic}: ${a.length} messages, ${b.length} in ${same}`);
  const i = a.findIndex((m, k) => !b[k] || m.t !== b[k].t || m.hex !== b[k].hex);
  check(i < 0, `${topic}: message ${i + 1} differs from ${same}'s: ${JSON.stringify(a[i], (k, v) => String(v))}`);
  if (i < 0) console.log(`${topic}: ${a.length} messages the same bytes at the same log times as ${same}'s`);
}
if (failures.length) {
  for (const f of failures.slice(0, 20)) console.log("FAIL: " + f);
  process.exit(1);
}
