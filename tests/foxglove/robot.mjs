// Foxglove's view of a URDF world, live (@foxglove/ws-protocol's FoxgloveClient on ws): the UR10 system
// (`dca run worlds/ur10/ur10_setpoint.dca --sim worlds/ur10/ur10.urdf --monitor --monitor-wait`):
//   node robot.mjs DCA SOURCE_DIR
// 1. /robot_description is advertised with schema std_msgs/String and, subscribed to, sends the UR10's URDF at
//    once ({"data": URDF}): what Foxglove's 3D panel loads the robot from.
// 2. /world/links/frames is advertised as foxglove.FrameTransforms; subscribed to, each message holds one
//    transform per link of the URDF (the root in "world", every other link in its parent), unit quaternions,
//    timestamps at simulated time; the elbow's child link turns as JointSetpoint drives the elbow to 1 rad.
// 3. The run ends DONE. Exit 1 on a failure.
import foxglove from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { deadline, pageToEnd, startRun } from "./dca_run.mjs";

const { FoxgloveClient } = foxglove;
const [dca, src] = process.argv.slice(2);
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

const run = startRun(dca, ["run", `${src}/worlds/ur10/ur10_setpoint.dca`, "--sim", `${src}/worlds/ur10/ur10.urdf`,
                        "--monitor", "--monitor-wait", "--as-fast-as-possible"]);
const { said } = run;
const FRAMES = "/world/links/frames", URDF = "/robot_description";

try {
  const [, url] = await said(/foxglove: (ws:\/\/\S+)/, 60000, "the foxglove line of dca run");
  const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  const channels = new Map();
  client.on("error", (e) => failures.push(`client error: ${e.message}`));
  const advertised = new Promise((resolve) => client.on("advertise", (list) => {
    for (const c of list) channels.set(c.topic, c);
    if (channels.get(FRAMES)?.schemaName === "foxglove.FrameTransforms" && channels.has(URDF)) resolve();
  }));
  await Promise.race([advertised, deadline(20000, `${FRAMES} as foxglove.FrameTransforms and ${URDF}`)]);
  const urdf = [], frames = [];
  let urdfSub, framesSub;
  client.on("message", ({ subscriptionId, timestamp, data }) => {
    const m = JSON.parse(new TextDecoder().decode(data));
    if (subscriptionId === urdfSub) urdf.push(m);
    else if (subscriptionId === framesSub) frames.push({ t: timestamp, m });
  });
  check(channels.get(URDF).schemaName === "std_msgs/String", `${URDF}: schema ${channels.get(URDF).schemaName}`);
  check(JSON.parse(channels.get(FRAMES).schema).title === "foxglove.FrameTransforms", `${FRAMES}: its JSON Schema`);
  // The first subscription starts time (--monitor-wait) once its tap is made: the frames from the first step on.
  framesSub = client.subscribe(channels.get(FRAMES).id);
  urdfSub = client.subscribe(channels.get(URDF).id);
  await said(/live: tapped world\.links\.frames/, 20000, "dca's tap of the link frames");
  await pageToEnd(url, run, failures);
  client.close();

  check(urdf.length === 1 && /<robot name="ur10"/.test(urdf[0]?.data ?? ""), `${URDF}: ${urdf.length} messages`);
  const links = [...(urdf[0]?.data ?? "").matchAll(/<link name="([^"]+)"/g)].map((m) => m[1]);
  check(frames.length > 100, `${frames.length} messages on ${FRAMES}`);
  check(frames[0]?.t === 10000000n, `the first frames at ${frames[0]?.t} ns, not at the first step (10 ms)`);
  let prev = -1n;
  for (const { t, m } of frames) {
    check(t >= prev, `${FRAMES}: timestamps going back`);
    prev = t;
    const children = m.transforms.map((x) => x.child_frame_id).sort();
    check(JSON.stringify(children) === JSON.stringify([...links].sort()), `frames of ${children}, links ${links}`);
    for (const x of m.transforms) {
      const r = x.rotation;
      check(Math.abs(Math.hypot(r.x, r.y, r.z, r.w) - 1) < 1e-6, `${x.child_frame_id}: not a unit quaternion`);
      check(BigInt(x.timestamp.sec) * 1000000000n + BigInt(x.timestamp.nsec) === t, `${x.child_frame_id}: its timestamp`);
    }
  }
  const root = frames[0]?.m.transforms[0];
  check(root?.parent_frame_id === "world", `the first frame: ${JSON.stringify(root)}`);
  // the elbow's child link (forearm_link) turns about its joint's axis: its rotation at the end differs
  const forearm = (i) => frames.at(i)?.m.transforms.find((x) => x.child_frame_id === "forearm_link")?.rotation;
  const a = forearm(0), b = forearm(-1);
  const dot = Math.abs(a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w);
  check(2 * Math.acos(Math.min(1, dot)) > 0.5, `forearm_link turned ${2 * Math.acos(Math.min(1, dot))} rad`);
  console.log(`foxglove: ${URDF} (${links.length} links), ${frames.length} FrameTransforms on ${FRAMES} ` +
              `(${Number(frames[0]?.t) / 1e9} .. ${Number(frames.at(-1)?.t) / 1e9} s), forearm turned ` +
              `${(2 * Math.acos(Math.min(1, dot))).toFixed(3)} rad`);
} catch (e) {
  failures.push(e.message);
  run.kill();
}
run.report(failures);
