// The same topics and schemas live and recorded (docs/monitor.md "Foxglove", docs/recording.md "Recording the
// world"), so one Foxglove layout serves a live run and its recording: the door run
//   dca run worlds/door/systems/door_open.dca --sim door --monitor --monitor-wait --as-fast-as-possible
//       --record OUT/door.mcap --record-ports all
// watched by @foxglove/ws-protocol's FoxgloveClient, then its recording read by @mcap/core (tests/mcap's, pinned
// there). Checks:
// 1. Every recorded channel of the world's signals and of the ports (/world/..., /main/...) is advertised live
//    under its name, with the same schema name and the same JSON Schema (as parsed: its title, the value's type,
//    items, size and units).
// 2. Every live channel of the world's signals is recorded (none live only, e.g. a status topic).
// 3. A message has the same shape live and recorded: /world/arm/q's {"value": [6 numbers]}, the door angle's.
// 4. /dca/events is in both, with the same schema.
//   node same_topics.mjs DCA SOURCE_DIR OUT_DIR
// Exit 1 on a failure.
import { mkdirSync } from "node:fs";
import { open } from "node:fs/promises";
import { createRequire } from "node:module";
import { join } from "node:path";
import { pathToFileURL } from "node:url";
import { deadline, foxgloveClient, pageToEnd, startRun } from "./dca_run.mjs";

const [dca, src, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };
const rec = join(out, "door.mcap");
// @mcap/core as tests/mcap installs it (scripts/setup: npm ci there)
const mcapCore = await import(pathToFileURL(createRequire(join(src, "tests/mcap/read_mcap.mjs")).resolve("@mcap/core")).href);
const { decompressHandlers } = await import(pathToFileURL(join(src, "tests/mcap/decompress.mjs")).href);

const run = startRun(dca, ["run", join(src, "worlds/door/systems/door_open.dca"), "--sim", "door", "--monitor",
                           "--monitor-wait", "--as-fast-as-possible", "--record", rec, "--record-ports", "all"]);
const ARM = "/world/arm/q", DOOR = "/world/door/angle";
try {
  const { url, client } = await foxgloveClient(run, failures);
  const live = new Map();
  const advertised = new Promise((resolve) => client.on("advertise", (list) => {
    for (const c of list) live.set(c.topic, c);
    if (live.has(ARM) && live.has(DOOR) && live.has("/dca/events")) resolve();
  }));
  await Promise.race([advertised, deadline(30000, `the advertise of ${ARM}, ${DOOR}`)]);
  const liveMsgs = new Map();
  const subs = new Map();
  client.on("message", ({ subscriptionId, data }) => {
    const topic = subs.get(subscriptionId);
    if (topic && !liveMsgs.has(topic)) liveMsgs.set(topic, JSON.parse(new TextDecoder().decode(data)));
  });
  for (const t of [ARM, DOOR]) subs.set(client.subscribe(live.get(t).id), t);
  await pageToEnd(url, run, failures);  // time starts (--monitor-wait); the run to its end
  client.close();
  check(/recorded .*door\.mcap: \d+ messages/.test(run.out()), "the run says what it recorded");

  // the recording, through its index
  const handle = await open(rec, "r");
  const size = BigInt((await handle.stat()).size);
  const reader = await mcapCore.McapIndexedReader.Initialize({
    readable: {
      size: async () => size,
      read: async (offset, length) => {
        const buf = new Uint8Array(Number(length));
        await handle.read(buf, 0, Number(length), Number(offset));
        return buf;
      },
    },
    decompressHandlers,
  });
  const recorded = new Map();
  for (const ch of reader.channelsById.values()) {
    const schema = reader.schemasById.get(ch.schemaId);
    recorded.set(ch.topic, { id: ch.id, schemaName: schema?.name ?? "",
                             schema: new TextDecoder().decode(schema?.data ?? new Uint8Array()) });
  }
  const recMsgs = new Map();
  for await (const m of reader.readMessages()) {
    const topic = [...recorded.entries()].find(([, c]) => c.id === m.channelId)?.[0];
    if (topic && !recMsgs.has(topic)) recMsgs.set(topic, JSON.parse(new TextDecoder().decode(m.data)));
    if (recMsgs.has(ARM) && recMsgs.has(DOOR)) break;
  }
  await handle.close();

  // 1. every recorded signal's and port's channel live, the same schema
  const signals = [...recorded.keys()].filter((t) => t.startsWith("/world/") || t.startsWith("/main/"));
  check(signals.some((t) => t.startsWith("/main/")) && signals.includes(ARM) && signals.includes(DOOR),
    `the recording holds the ports and ${ARM}, ${DOOR}: ${signals.join(", ")}`);
  let same = 0;
  for (const t of signals) {
    const l = live.get(t), r = recorded.get(t);
    if (!l) { check(false, `${t} is recorded but not live`); continue; }
    const ok = l.schemaName === r.schemaName && JSON.stringify(JSON.parse(l.schema)) === JSON.stringify(JSON.parse(r.schema));
    check(ok, `${t}: live ${l.schemaName} ${l.schema} vs recorded ${r.schemaName} ${r.schema}`);
    if (ok) same++;
  }
  // 2. no world signal live only
  for (const t of live.keys()) {
    if (t.startsWith("/world/")) check(recorded.has(t), `${t} is live but not recorded`);
  }
  // 3. the same message shape
  for (const t of [ARM, DOOR]) {
    const l = liveMsgs.get(t), r = recMsgs.get(t);
    const shape = (m) => JSON.stringify(m, (k, v) => (typeof v === "number" ? 0 : v));
    check(l && r && shape(l) === shape(r), `${t}: a live message ${JSON.stringify(l)}, a recorded one ${JSON.stringify(r)}`);
  }
  check(Array.isArray(recMsgs.get(ARM)?.value) && recMsgs.get(ARM).value.length === 6, `${ARM}: {"value": [6 numbers]}`);
  // 4. the run's lines
  check(live.get("/dca/events")?.schemaName === recorded.get("/dca/events")?.schemaName &&
        live.get("/dca/events")?.schemaName === "dca/events", "/dca/events live and recorded with the schema dca/events");
  console.log(`${same} channels the same live and recorded (${signals.filter((t) => t.startsWith("/world/")).length} ` +
              `world signals), ${live.size} live, ${recorded.size} recorded`);
} catch (e) {
  failures.push(String(e));
  run.kill();
}
run.report(failures);
