// An independent check of a split recording (`--record-split DURATION`) with @mcap/core:
//   node read_split.mjs SECONDS "<the 'recorded FILE: N messages on K channels (...), ..., in F files A .. B' line>"
//       FILE-000.mcap FILE-001.mcap ...
// Each file opens with the indexed reader and holds every channel of the recording (with its schema); file k holds
// the messages of [k * SECONDS, (k + 1) * SECONDS) of log time, none else; the files' messages add up, topic by
// topic, to the counts dca printed. Exit 1 on a mismatch.
import { openIndexed } from "./decompress.mjs";

const [seconds, recorded, ...files] = process.argv.slice(2);
const m = recorded?.match(/: (\d+) messages on (\d+) channels \((.*)\), (\d+) chunks.*, in (\d+) files/);
if (!m || files.length === 0) {
  console.error("usage: node read_split.mjs SECONDS RECORDED_LINE FILE-000.mcap ...");
  process.exit(2);
}
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };
check(Number(m[5]) === files.length, `dca says ${m[5]} files, ${files.length} given`);
const span = BigInt(Math.round(Number(seconds) * 1e9));
const want = new Map(m[3].split(", ").map((p) => [p.split(" ")[0], BigInt(p.split(" ")[1])]));
const counts = new Map();
let total = 0n;
for (const [k, file] of files.entries()) {
  const { reader, handle } = await openIndexed(file);
  const topics = new Set([...reader.channelsById.values()].map((c) => c.topic));
  check(topics.size === Number(m[2]), `${file}: ${topics.size} channels, dca: ${m[2]}`);
  for (const t of want.keys()) check(topics.has(t), `${file}: no channel ${t}`);
  for (const c of reader.channelsById.values()) check(reader.schemasById.has(c.schemaId), `${file}: ${c.topic} has no schema`);
  let n = 0n;
  for await (const msg of reader.readMessages({ validateCrcs: true })) {
    const topic = reader.channelsById.get(msg.channelId).topic;
    counts.set(topic, (counts.get(topic) ?? 0n) + 1n);
    n++;
    check(msg.logTime >= BigInt(k) * span && msg.logTime < BigInt(k + 1) * span,
          `${file}: a message of ${topic} at ${msg.logTime} ns, outside file ${k}'s window`);
  }
  check(reader.statistics?.messageCount === n, `${file}: statistics ${reader.statistics?.messageCount}, read ${n}`);
  total += n;
  await handle.close();
}
check(total === BigInt(m[1]), `the files hold ${total} messages, dca: ${m[1]}`);
for (const [t, n] of want) check((counts.get(t) ?? 0n) === n, `${t}: the files hold ${counts.get(t)}, dca: ${n}`);
console.log(`@mcap/core: ${files.length} files of ${seconds} s, each with every one of ${m[2]} channels, ${total} messages`);
if (failures.length) {
  for (const f of failures.slice(0, 20)) console.error(`FAIL ${f}`);
  process.exit(1);
}
