// A URDF world's recording read by @mcap/core (independent of dca):
//   node read_robot.mjs FILE.mcap URDF_FILE
// /robot_description holds one message, {"data": the URDF file's text}, schema std_msgs/String; /world/links/frames
// (schema foxglove.FrameTransforms, its JSON Schema titled so) holds, at every recorded tick, one transform per
// <link> of the URDF: the root link in "world", every other link in the parent link of its joint, unit
// quaternions, each transform's timestamp its message's log time. The joints' channels (/world/joint/J/position)
// agree with the frames: a revolute joint's child link turns, relative to its parent, by the joint's position.
// Exit 1 on a failure.
import { readFile } from "node:fs/promises";
import { openIndexed } from "./decompress.mjs";

const [file, urdfFile] = process.argv.slice(2);
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };
const urdf = await readFile(urdfFile, "utf8");
const links = [...urdf.matchAll(/<link name="([^"]+)"/g)].map((m) => m[1]);
const parentOf = new Map([...urdf.matchAll(/<joint name="([^"]+)"[\s\S]*?<parent link="([^"]+)"\/>\s*<child link="([^"]+)"\/>/g)]
  .map((m) => [m[3], { joint: m[1], parent: m[2] }]));

const { reader, handle } = await openIndexed(file);
const byTopic = new Map([...reader.channelsById.values()].map((c) => [c.topic, c]));
const schemaOf = (topic) => reader.schemasById.get(byTopic.get(topic)?.schemaId);
check(schemaOf("/world/links/frames")?.name === "foxglove.FrameTransforms", "/world/links/frames: not foxglove.FrameTransforms");
check(JSON.parse(new TextDecoder().decode(schemaOf("/world/links/frames")?.data ?? new Uint8Array()) || "{}").title ===
      "foxglove.FrameTransforms", "/world/links/frames: its JSON Schema");
check(schemaOf("/robot_description")?.name === "std_msgs/String", "/robot_description: not std_msgs/String");

const descriptions = [], frames = [], joints = new Map();  // joint -> Map(logTime -> position)
for await (const msg of reader.readMessages({ validateCrcs: true })) {
  const topic = reader.channelsById.get(msg.channelId).topic;
  const value = JSON.parse(new TextDecoder().decode(msg.data));
  if (topic === "/robot_description") descriptions.push(value);
  if (topic === "/world/links/frames") frames.push({ t: msg.logTime, value });
  const j = topic.match(/^\/world\/joint\/(.+)\/position$/);
  if (j) {
    if (!joints.has(j[1])) joints.set(j[1], new Map());
    joints.get(j[1]).set(msg.logTime, value.value[0]);
  }
}
check(descriptions.length === 1 && descriptions[0].data === urdf, `/robot_description: ${descriptions.length} messages, the URDF's text?`);
check(frames.length > 10, `${frames.length} FrameTransforms`);
let turned = 0;
for (const { t, value } of frames) {
  const byChild = new Map(value.transforms.map((x) => [x.child_frame_id, x]));
  check(byChild.size === links.length && links.every((l) => byChild.has(l)), `at ${t}: frames of ${[...byChild.keys()]}, links ${links}`);
  for (const [child, x] of byChild) {
    const want = parentOf.get(child)?.parent ?? "world";
    check(x.parent_frame_id === want, `${child} in ${x.parent_frame_id}, not ${want}`);
    check(BigInt(x.timestamp.sec) * 1000000000n + BigInt(x.timestamp.nsec) === t, `${child}: timestamp not the log time`);
    const r = x.rotation;
    check(Math.abs(Math.hypot(r.x, r.y, r.z, r.w) - 1) < 1e-6, `${child}: not a unit quaternion`);
  }
  // the elbow's child link turns about the elbow's axis by the elbow's position (its origin has no rotation
  // about that axis in worlds/ur10: the angle between successive frames equals the joint's change)
  const q = joints.get("elbow_joint")?.get(t);
  if (q !== undefined && frames[0]) {
    const a = frames[0].value.transforms.find((x) => x.child_frame_id === "forearm_link").rotation;
    const b = byChild.get("forearm_link").rotation;
    const angle = 2 * Math.acos(Math.min(1, Math.abs(a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w)));
    const q0 = joints.get("elbow_joint").get(frames[0].t);
    check(Math.abs(angle - Math.abs(q - q0)) < 1e-6, `at ${t}: forearm turned ${angle}, the elbow moved ${q - q0}`);
    turned = Math.max(turned, angle);
  }
}
check(turned > 0.5, `the forearm turned at most ${turned} rad`);
await handle.close();
console.log(`@mcap/core: /robot_description (${links.length} links), ${frames.length} foxglove.FrameTransforms of every ` +
            `link; the forearm turned up to ${turned.toFixed(3)} rad with the elbow`);
if (failures.length) {
  for (const f of failures.slice(0, 20)) console.error(`FAIL ${f}`);
  process.exit(1);
}
