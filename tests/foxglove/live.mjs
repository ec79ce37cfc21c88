// A Foxglove WebSocket client (@foxglove/ws-protocol's FoxgloveClient on ws) against a running door system in
// simulated time (`dca run door_open.dca --sim door --monitor --monitor-wait --trace TRACE`):
//   node live.mjs DCA SYSTEM WORK_DIR
// 1. Without the token, and with a wrong one, the WebSocket is refused (401) and nothing is advertised.
// 2. With it: serverInfo, then the channels (every port of the tree and every world signal, JSON Schema); the
//    client subscribes to PORT (below), waits until dca says it tapped it, then opens the monitor's page protocol
//    (dca.monitor.v1), which starts time (--monitor-wait), and receives the port's samples as binary Message Data
//    (and those of a world signal, /world/door/angle, tapped at the world):
//    at least MIN of them, timestamps never going back (simulated time, ns), each message its channel's JSON
//    and, where the trace has one sample at that tick, the trace's value.
// 3. The run ends DONE. Prints what it received; exit 1 on a failure.
import { readFile } from "node:fs/promises";
import foxglove from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { deadline, startRun } from "./dca_run.mjs";

const { FoxgloveClient } = foxglove;

const [dca, system, work] = process.argv.slice(2);
const PORT = "/main/dooropensyst/motionctrl/xr4000/Cmd";
const SIGNAL = "/world/door/angle";  // a world signal, tapped at the world
const MIN = 500;
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };

const trace = `${work}/live.trace`;
const run = startRun(dca, ["run", system, "--sim", "door", "--monitor", "--monitor-wait", "--as-fast-as-possible", "--trace", trace]);
const { said, ended } = run;

try {
  const [, url] = await said(/foxglove: (ws:\/\/\S+)/, 60000, "the foxglove line of dca run");
  const base = url.replace(/\?.*$/, "");

  // 1. no token, a wrong token: refused before anything is said
  for (const bad of [base, `${base}?token=0123456789abcdef0123456789abcdef`]) {
    const status = await new Promise((resolve) => {
      const ws = new WebSocket(bad, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
      ws.on("unexpected-response", (_req, res) => resolve(res.statusCode));
      ws.on("open", () => { ws.close(); resolve("open"); });
      ws.on("error", () => resolve("error"));
    });
    check(status === 401, `${bad}: ${status}, not refused with 401`);
  }

  // 2. with the token
  const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  let info;
  const channels = new Map();
  const got = [];
  let subscription;
  client.on("serverInfo", (i) => { info = i; });
  client.on("error", (e) => failures.push(`client error: ${e.message}`));
  let advertisedPort = 0;
  const advertised = new Promise((resolve) => client.on("advertise", (list) => {
    for (const c of list) channels.set(c.topic, c);
    advertisedPort += list.filter((c) => c.topic === PORT).length;
    if (channels.has(PORT)) resolve();
  }));
  const door = [];
  let doorSubscription;
  client.on("message", ({ subscriptionId, timestamp, data }) => {
    const value = JSON.parse(new TextDecoder().decode(data));
    if (subscriptionId === doorSubscription) return door.push({ t: timestamp, value });
    if (subscriptionId !== subscription) return failures.push(`a message for subscription ${subscriptionId}`);
    got.push({ t: timestamp, value });
  });
  await Promise.race([advertised, deadline(20000, `the advertise of ${PORT}`)]);
  check(info?.name?.startsWith("dca"), `serverInfo: ${JSON.stringify(info)}`);
  const cmd = channels.get(PORT);
  check(cmd.encoding === "json" && cmd.schemaEncoding === "jsonschema", `${PORT}: ${cmd.encoding}/${cmd.schemaEncoding}`);
  const schema = JSON.parse(cmd.schema);
  check(schema.properties?.value?.maxItems === 3, `${PORT}: schema ${cmd.schema}`);
  check([...channels.keys()].some((t) => t.startsWith("/world/")), "no world signal advertised");
  subscription = client.subscribe(cmd.id);
  check(channels.has(SIGNAL), `${SIGNAL} not advertised`);
  if (channels.has(SIGNAL)) doorSubscription = client.subscribe(channels.get(SIGNAL).id);
  // every port and world signal is tapped before time starts (--monitor-taps all, the default)
  await said(/live: tapped (\d+) of \1 ports and world signals from the start/, 20000, "dca's taps of every port");

  // time starts when a monitor page connects
  const page = new WebSocket(url, ["dca.monitor.v1"]);
  page.on("error", (e) => failures.push(`page: ${e.message}`));
  const start = Date.now();
  while (got.length < MIN && Date.now() - start < 60000) await new Promise((r) => setTimeout(r, 20));
  check(got.length >= MIN, `${got.length} samples of ${PORT} received, wanted ${MIN}`);
  const code = await Promise.race([ended, deadline(120000, "the end of the run")]);
  check(code === 0, `dca run ended with ${code}`);
  client.close();
  page.close();

  // the samples against the trace: timestamps increasing, values the trace's where the tick had one sample
  const points = new Map();  // tick (ns) -> [values written at it, in order: one D line per advance]
  let last = 0;
  for (const line of (await readFile(trace, "utf8")).split("\n")) {
    const m = line.match(/^(\d+) D main\.dooropensyst\.motionctrl\.xr4000\.Cmd n=(\d+) digest=\S+ value=(.*)$/);
    if (!m) continue;
    const n = Number(m[2]);
    if (!points.has(m[1])) points.set(m[1], { first: last, n, value: m[3] });
    else Object.assign(points.get(m[1]), { n, value: m[3] });
    last = n;
  }
  let compared = 0, prev = -1n;
  const per = new Map();
  for (const g of got) {
    check(g.t >= prev, `timestamps going back: ${g.t} after ${prev}`);
    prev = g.t;
    per.set(String(g.t), (per.get(String(g.t)) ?? 0) + 1);
  }
  for (const g of got) {
    const p = points.get(String(g.t));
    check(p !== undefined, `a sample at ${g.t} ns: no such tick in the trace`);
    if (!p || p.n - p.first !== 1 || per.get(String(g.t)) !== 1) continue;
    compared++;
    check(JSON.stringify(g.value.value) === JSON.stringify(JSON.parse(p.value)),
          `at ${g.t} ns: ${JSON.stringify(g.value)}, the trace: ${p.value}`);
  }
  check(compared >= MIN / 2, `only ${compared} samples compared with the trace`);
  // the world's door angle: its samples at the ticks the world published them, the door opening
  check(door.length >= MIN, `${door.length} samples of ${SIGNAL}`);
  check(door.every((d, i) => i === 0 || d.t >= door[i - 1].t), `${SIGNAL}: timestamps going back`);
  check(Math.max(...door.map((d) => d.value.value[0])) > 1.0, `${SIGNAL}: the door never opened past 1 rad`);
  check(advertisedPort === 1, `${PORT} advertised ${advertisedPort} times (its tap must not advertise it again)`);
  console.log(`foxglove: ${door.length} samples of ${SIGNAL} (up to ${Math.max(...door.map((d) => d.value.value[0])).toFixed(3)} rad)`);
  console.log(`foxglove: ${channels.size} channels advertised, ${got.length} samples of ${PORT} received ` +
              `(${Number(got[0]?.t) / 1e9} .. ${Number(got.at(-1)?.t) / 1e9} s simulated), ${compared} equal to the ` +
              `trace's; refused without the token and with a wrong one (401)`);
} catch (e) {
  failures.push(e.message);
  run.kill();
}
run.report(failures);
