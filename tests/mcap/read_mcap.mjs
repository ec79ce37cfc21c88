// An independent check of a dca MCAP recording with @mcap/core (the reader Foxglove's tools are built on):
//   node read_mcap.mjs FILE.mcap "<the 'recorded FILE: N messages on K channels (/topic n, ...), C chunks' line>"
// Opens FILE with the indexed reader (which needs the summary: footer, summary offsets, chunk indexes,
// channels and schemas), checks that every channel has a JSON Schema and JSON messages, that the statistics
// and the messages read through the chunk indexes match the counts dca printed, then reads the file again
// front to back with the streaming reader (every record, CRCs validated). Prints what it found; exit 1 on a
// mismatch.
import { open } from "node:fs/promises";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";

const [file, recorded] = process.argv.slice(2);
if (!file || !recorded) {
  console.error("usage: node read_mcap.mjs FILE.mcap RECORDED_LINE");
  process.exit(2);
}
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

// What dca printed: total, per topic, chunks.
const m = recorded.match(/: (\d+) messages on (\d+) channels \((.*)\), (\d+) chunks/);
if (!m) { console.error(`cannot parse dca's line: ${recorded}`); process.exit(2); }
const want = { total: BigInt(m[1]), channels: Number(m[2]), chunks: Number(m[4]), topics: new Map() };
for (const part of m[3].split(", ")) {
  const [topic, n] = part.split(" ");
  want.topics.set(topic, BigInt(n));
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
const reader = await McapIndexedReader.Initialize({ readable });

check(reader.footer.summaryStart > 0n, "footer: no summary section");
check(reader.footer.summaryOffsetStart > 0n, "footer: no summary offset section");
for (const op of [0x03, 0x04, 0x08, 0x0b]) check(reader.summaryOffsetsByOpcode.has(op), `no summary offset for op ${op}`);
check(reader.chunkIndexes.length === want.chunks, `chunk indexes: ${reader.chunkIndexes.length}, dca: ${want.chunks}`);
check(reader.channelsById.size === want.channels, `channels: ${reader.channelsById.size}, dca: ${want.channels}`);
for (const [id, ch] of reader.channelsById) {
  const schema = reader.schemasById.get(ch.schemaId);
  check(schema !== undefined, `channel ${id} (${ch.topic}) has no schema`);
  check(schema?.encoding === "jsonschema", `channel ${ch.topic}: schema encoding ${schema?.encoding}`);
  if (schema) JSON.parse(new TextDecoder().decode(schema.data));
  check(ch.messageEncoding === "json", `channel ${ch.topic}: message encoding ${ch.messageEncoding}`);
}
const stats = reader.statistics;
check(stats !== undefined, "no statistics record");
check(stats?.messageCount === want.total, `statistics: ${stats?.messageCount} messages, dca: ${want.total}`);

const counts = new Map();
let last = -1n;
for await (const msg of reader.readMessages({ validateCrcs: true })) {
  const topic = reader.channelsById.get(msg.channelId).topic;
  counts.set(topic, (counts.get(topic) ?? 0n) + 1n);
  check(msg.logTime >= last, "messages out of log-time order");
  last = msg.logTime;
  JSON.parse(new TextDecoder().decode(msg.data));
}
for (const [topic, n] of want.topics) {
  check(counts.get(topic) === n, `${topic}: read ${counts.get(topic)}, dca: ${n}`);
  check(stats?.channelMessageCounts.get([...reader.channelsById].find(([, c]) => c.topic === topic)[0]) === n,
        `${topic}: statistics count differs`);
}

// Front to back, every record.
const stream = new McapStreamReader({ validateCrcs: true });
stream.append(new Uint8Array(await handle.readFile()));
let records = 0, streamed = 0n;
for (let r; (r = stream.nextRecord()); ) {
  records++;
  if (r.type === "Message") streamed++;
}
check(stream.done(), "streaming reader: file not complete");
check(streamed === want.total, `streaming reader: ${streamed} messages, dca: ${want.total}`);
await handle.close();

console.log(`@mcap/core: ${reader.channelsById.size} channels with schemas, ${reader.chunkIndexes.length} chunk indexes, ` +
  `${stats?.messageCount} messages (${[...counts].map(([t, n]) => `${t} ${n}`).join(", ")}), ${records} records streamed`);
if (failures.length) {
  for (const f of failures) console.error(`FAIL ${f}`);
  process.exit(1);
}
