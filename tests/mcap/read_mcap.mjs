// An independent check of a dca MCAP recording with @mcap/core (the reader Foxglove's tools are built on):
//   node read_mcap.mjs FILE.mcap "<the 'recorded FILE: N messages on K channels (/topic n, ...), C chunks' line>"
//   node read_mcap.mjs FILE.mcap --lines LINES   (a recording of `dca run --sim`: LINES holds the run's
//                                                 "[sim T] text" lines, which /dca/events must hold, in order)
//   node read_mcap.mjs FILE.mcap --compression zstd|lz4|none   (any recording, e.g. a black box's file: every
//       chunk compressed so, and the messages read as many as its statistics count)
//   node read_mcap.mjs FILE.mcap "<recorded line>" --trace TRACE   (a recording with --record-ports and --trace:
//       each port's channel /main/... holds, at every tick of the trace, as many messages up to that tick as the
//       trace counts for the port then (so every sample is at the tick its leaf wrote it), and its last message
//       is the trace's last value; every message fits its channel's JSON Schema)
//   node read_mcap.mjs FILE.mcap "<recorded line>" --rt PATH   (a wall-clock run's recording: the leaf PATH's
//       figures on its real-time thread on /dca/rt/<PATH, dots as slashes>, each field declared by the channel's
//       JSON Schema with its type, runs never going back, the last one's runs > 0, log times on the wall clock)
// Opens FILE with the indexed reader (which needs the summary: footer, summary offsets, chunk indexes,
// channels and schemas), checks that every channel has a JSON Schema and JSON messages, that the statistics
// and the messages read through the chunk indexes match the counts dca printed, then reads the file again
// front to back with the streaming reader (every record, CRCs validated). Prints what it found; exit 1 on a
// mismatch.
import { open } from "node:fs/promises";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { decompressHandlers } from "./decompress.mjs";

const [file, recorded] = process.argv.slice(2);
const traceFile = process.argv[4] === "--trace" ? process.argv[5] : undefined;
const rtPath = process.argv[4] === "--rt" ? process.argv[5] : undefined;
if (!file || !recorded) {
  console.error("usage: node read_mcap.mjs FILE.mcap RECORDED_LINE");
  process.exit(2);
}
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

// What dca printed: total, per topic, chunks; or, with --lines, the run's stamped lines.
let want, lines, compression;
if (recorded === "--compression") {
  compression = process.argv[4] === "none" ? "" : process.argv[4];
} else if (recorded === "--lines") {
  const { readFile } = await import("node:fs/promises");
  lines = (await readFile(process.argv[4], "utf8")).split("\n").filter((l) => l.startsWith("[sim "))
    .map((l) => ({ t: Number(l.slice(5, l.indexOf("]"))), text: l.slice(l.indexOf("]") + 2) }));
} else {
  const m = recorded.match(/: (\d+) messages on (\d+) channels \((.*)\), (\d+) chunks/);
  if (!m) { console.error(`cannot parse dca's line: ${recorded}`); process.exit(2); }
  want = { total: BigInt(m[1]), channels: Number(m[2]), chunks: Number(m[4]), topics: new Map() };
  compression = recorded.match(/ chunks, (zstd|lz4) [\d.]+x/)?.[1] ?? "";
  for (const part of m[3].split(", ")) {
    const [topic, n] = part.split(" ");
    want.topics.set(topic, BigInt(n));
  }
}

const handle = await open(file, "r");
const size = BigInt((await handle.stat()).size);
const readable = {
  size: async () => size,
  read: async (offset, length) => {
    const buf = new Uint8Array(Number(length));
    await handle.read(buf, 0, Number(length), Number(offset));
    return buf;
  },
};
const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });

check(reader.footer.summaryStart > 0n, "footer: no summary section");
check(reader.footer.summaryOffsetStart > 0n, "footer: no summary offset section");
for (const op of [0x03, 0x04, 0x08, 0x0b]) check(reader.summaryOffsetsByOpcode.has(op), `no summary offset for op ${op}`);
check(reader.chunkIndexes.length > 0, "no chunk indexes");
if (compression !== undefined) {
  for (const ci of reader.chunkIndexes) check(ci.compression === compression, `a chunk compressed '${ci.compression}', not '${compression}'`);
}
if (want) {
  check(reader.chunkIndexes.length === want.chunks, `chunk indexes: ${reader.chunkIndexes.length}, dca: ${want.chunks}`);
  check(reader.channelsById.size === want.channels, `channels: ${reader.channelsById.size}, dca: ${want.channels}`);
}
for (const [id, ch] of reader.channelsById) {
  const schema = reader.schemasById.get(ch.schemaId);
  check(schema !== undefined, `channel ${id} (${ch.topic}) has no schema`);
  check(schema?.encoding === "jsonschema", `channel ${ch.topic}: schema encoding ${schema?.encoding}`);
  if (schema) JSON.parse(new TextDecoder().decode(schema.data));
  check(ch.messageEncoding === "json", `channel ${ch.topic}: message encoding ${ch.messageEncoding}`);
}
const stats = reader.statistics;
check(stats !== undefined, "no statistics record");
if (want) check(stats?.messageCount === want.total, `statistics: ${stats?.messageCount} messages, dca: ${want.total}`);

const counts = new Map();
const events = [];
const portMessages = new Map();  // topic -> [{t, value}] in log-time order
const rtMessages = [];  // with --rt: the leaf's /dca/rt messages, {t, value, schema}
let last = -1n;
for await (const msg of reader.readMessages({ validateCrcs: true })) {
  const topic = reader.channelsById.get(msg.channelId).topic;
  counts.set(topic, (counts.get(topic) ?? 0n) + 1n);
  check(msg.logTime >= last, "messages out of log-time order");
  last = msg.logTime;
  const value = JSON.parse(new TextDecoder().decode(msg.data));
  if (topic === "/dca/events") events.push({ t: Number(msg.logTime) / 1e9, ...value });
  if (rtPath && topic === "/dca/rt/" + rtPath.replaceAll(".", "/")) {
    const schema = JSON.parse(new TextDecoder().decode(reader.schemasById.get(reader.channelsById.get(msg.channelId).schemaId).data));
    rtMessages.push({ t: msg.logTime, value, schema });
  }
  if (topic.startsWith("/main/")) {
    if (!portMessages.has(topic)) portMessages.set(topic, []);
    portMessages.get(topic).push({ t: msg.logTime, value: value.value });
    const schema = JSON.parse(new TextDecoder().decode(reader.schemasById.get(reader.channelsById.get(msg.channelId).schemaId).data));
    const v = schema.properties?.value;
    if (v?.type === "array") check(Array.isArray(value.value) && (v.maxItems === undefined || value.value.length === v.maxItems),
      `${topic}: ${JSON.stringify(value.value)} does not fit its schema`);
    if (v?.type === "number") check(typeof value.value === "number" || value.value === null, `${topic}: not a number`);
  }
}
if (lines || !want) {
  const total = [...counts.values()].reduce((a, b) => a + b, 0n);
  check(stats?.messageCount === total, `statistics: ${stats?.messageCount} messages, read ${total}`);
}
if (lines) {
  // (a dca run's world signals: one channel each, as live)
  for (const topic of ["/world/arm/q", "/world/door/angle"]) check((counts.get(topic) ?? 0n) > 0n, `no ${topic} messages`);
  check(events.length === lines.length, `/dca/events: ${events.length} messages, the run printed ${lines.length} lines`);
  // in the order of their times (the indexed reader sorts by log time; equal times keep the run's order)
  const sorted = lines.map((l, i) => ({ ...l, i })).sort((a, b) => a.t - b.t || a.i - b.i);
  sorted.forEach((l, i) => {
    const e = events[i];
    check(e && e.line === l.text && Math.abs(e.t - l.t) < 0.0006, `event ${i}: ${JSON.stringify(e)} vs ${l.t} ${l.text}`);
  });
  check(events.some((e) => e.path === "main.dooropensyst.dooropen" && e.state === "running"), "no transition of dooropen");
}
for (const [topic, n] of want?.topics ?? []) {
  check(counts.get(topic) === n, `${topic}: read ${counts.get(topic)}, dca: ${n}`);
  check(stats?.channelMessageCounts.get([...reader.channelsById].find(([, c]) => c.topic === topic)[0]) === n,
        `${topic}: statistics count differs`);
}

// With --trace: every port at its ticks, as the trace counts it.
if (traceFile) {
  const { readFile } = await import("node:fs/promises");
  const trace = new Map();  // port path -> [{t, n, value}]
  for (const line of (await readFile(traceFile, "utf8")).split("\n")) {
    const m = line.match(/^(\d+) D (\S+) n=(\d+) digest=\S+ value=(.*)$/);
    if (!m) continue;
    if (!trace.has(m[2])) trace.set(m[2], []);
    trace.get(m[2]).push({ t: BigInt(m[1]), n: Number(m[3]), value: m[4] });
  }
  let ports = 0, ticks = 0;
  for (const [topic, msgs] of portMessages) {
    const path = topic.slice(1).replaceAll("/", ".");
    const points = trace.get(path);
    check(points !== undefined, `${topic}: the trace has no port ${path}`);
    if (!points) continue;
    ports++;
    let k = 0;
    points.forEach((p, i) => {  // messages with log time <= the tick: the trace's count at that tick's end
      if (i + 1 < points.length && points[i + 1].t === p.t) return;  // a barrier: the tick's last count
      while (k < msgs.length && msgs[k].t <= p.t) k++;
      ticks++;
      check(k === p.n, `${topic}: ${k} messages by ${p.t} ns, the trace counts ${p.n}`);
    });
    const last = points[points.length - 1];
    check(msgs.length === last.n, `${topic}: ${msgs.length} messages, the trace's last count ${last.n}`);
    check(JSON.stringify(msgs[msgs.length - 1].value) === JSON.stringify(JSON.parse(last.value)),
          `${topic}: last value ${JSON.stringify(msgs[msgs.length - 1].value)}, the trace's ${last.value}`);
  }
  check(ports > 0, "no port channels (/main/...)");
  for (const path of trace.keys())  // every leaf's output (the world's signals are on /world/... channels)
    if (!path.startsWith("world.")) check(portMessages.has("/" + path.replaceAll(".", "/")), `${path}: in the trace, not recorded`);
  console.log(`trace ${traceFile}: ${ports} ports recorded at their ticks (${ticks} trace points checked)`);
}

// With --rt: the leaf's real-time figures.
if (rtPath) {
  check(rtMessages.length > 0, `no /dca/rt messages of ${rtPath}`);
  const fits = (v, s, at) => {  // the value's fields are the schema's, of its types
    if (s.type === "object") {
      check(typeof v === "object" && v !== null && !Array.isArray(v), `${at}: not an object`);
      for (const [k, x] of Object.entries(v ?? {})) {
        check(s.properties?.[k] !== undefined, `${at}.${k}: not in the schema`);
        if (s.properties?.[k]) fits(x, s.properties[k], `${at}.${k}`);
      }
    } else if (s.type === "array") {
      check(Array.isArray(v), `${at}: not an array`);
      for (const x of v ?? []) fits(x, s.items, `${at}[]`);
    } else if (s.type === "integer") check(Number.isInteger(v), `${at}: ${v} is not an integer`);
    else if (s.type === "number") check(typeof v === "number", `${at}: ${v} is not a number`);
    else if (s.type === "string") check(typeof v === "string", `${at}: not a string`);
  };
  let runs = -1;
  const wall = BigInt(Date.now()) * 1000000n;
  for (const m of rtMessages) {
    fits(m.value, m.schema, "rt");
    check(m.value.path === rtPath, `rt.path ${m.value.path}`);
    check(m.value.runs >= runs, `runs went back: ${m.value.runs} after ${runs}`);
    runs = m.value.runs;
    check(m.t > wall - 3600n * 1000000000n && m.t <= wall, `log time ${m.t} is not on the wall clock`);
  }
  check(runs > 0, `the last figures of ${rtPath} count no runs`);
  console.log(`/dca/rt: ${rtMessages.length} messages of ${rtPath}, each fits its schema; runs ${runs} at the end`);
}

// Front to back, every record.
const stream = new McapStreamReader({ validateCrcs: true, decompressHandlers });
stream.append(new Uint8Array(await handle.readFile()));
let records = 0, streamed = 0n;
for (let r; (r = stream.nextRecord()); ) {
  records++;
  if (r.type === "Message") streamed++;
}
check(stream.done(), "streaming reader: file not complete");
check(streamed === stats?.messageCount, `streaming reader: ${streamed} messages, statistics: ${stats?.messageCount}`);
await handle.close();

console.log(`@mcap/core: ${reader.channelsById.size} channels with schemas, ${reader.chunkIndexes.length} chunk indexes, ` +
  `${stats?.messageCount} messages${compression ? ` in ${compression} chunks` : ""} (${[...counts].map(([t, n]) => `${t} ${n}`).join(", ")}), ${records} records streamed` +
  (lines ? `; /dca/events holds the run's ${lines.length} lines` : ""));
if (failures.length) {
  for (const f of failures) console.error(`FAIL ${f}`);
  process.exit(1);
}
