// Foxglove at parity with the recordings (@foxglove/ws-protocol's FoxgloveClient on ws), on a run in simulated time
// whose start waits for a viewer (`dca run scripts/systems/test_live.dca --sim mock:worlds/ur10/ur10.urdf --monitor
// --monitor-wait`), with no monitor page at all:
//   node parity.mjs DCA SOURCE_DIR
// 1. serverInfo has the capabilities `time` and `connectionGraph` (and `parameters`).
// 2. The Foxglove client alone starts time (--monitor-wait) when it subscribes, and the run ends DONE.
// 3. Time messages carry simulated time: never backwards, up to the run's end (1 s), and the samples' and the
//    lines' timestamps are on the same clock.
// 4. /dca/events is advertised with the recordings' schema (dca/events) and carries the run's lines as the
//    recordings hold them ({line, path, state}), the root's DONE among them.
// 5. subscribeConnectionGraph answers connectionGraphUpdate: each output's topic published by its leaf
//    (/main/one/Out by main.one) and read by the leaves its connections reach (main.scale).
// Exit 1 on a failure.
import { deadline, foxgloveClient, startLiveRun } from "./dca_run.mjs";

const [dca, src] = process.argv.slice(2);
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };
const show = (x) => JSON.stringify(x, (k, v) => (typeof v === "bigint" ? v.toString() : v));

const run = startLiveRun(dca, src);

try {
  const { ws, client, info: serverInfo } = await foxgloveClient(run, failures);
  const channels = new Map();
  const advertised = new Promise((resolve) => client.on("advertise", (list) => {
    for (const c of list) channels.set(c.topic, c);
    if (channels.has("/dca/events") && channels.has("/main/scale/Out")) resolve();
  }));
  const info = await serverInfo;
  for (const cap of ["time", "connectionGraph", "parameters"]) {
    check(info.capabilities.includes(cap), `serverInfo's capabilities ${show(info.capabilities)} lack ${cap}`);
  }
  await Promise.race([advertised, deadline(20000, "the channels /dca/events and /main/scale/Out")]);
  const events = channels.get("/dca/events");
  check(events.schemaName === "dca/events" && events.encoding === "json" &&
        JSON.parse(events.schema).properties?.state?.type === "string", `/dca/events: ${show(events)}`);

  const times = [], lines = [], samples = [];
  let graph = null;
  client.on("time", (m) => times.push(m.timestamp));
  client.on("connectionGraphUpdate", (m) => { graph = m; });
  const subs = new Map([[1, "/dca/events"], [2, "/main/scale/Out"]]);
  client.on("message", (m) => {
    const text = new TextDecoder().decode(m.data);
    if (subs.get(m.subscriptionId) === "/dca/events") lines.push({ t: m.timestamp, msg: JSON.parse(text) });
    else samples.push({ t: m.timestamp, msg: JSON.parse(text) });
  });
  ws.send(JSON.stringify({ op: "subscribe", subscriptions: [...subs].map(([id, topic]) => ({ id, channelId: channels.get(topic).id })) }));
  ws.send(JSON.stringify({ op: "subscribeConnectionGraph" }));

  // no page: the Foxglove client alone started time, and the run ends
  const code = await Promise.race([run.ended, deadline(120000, "the end of the run")]);
  check(code === 0, `dca run ended with ${code}`);
  check(!/no port has the topic/.test(run.out()), "a subscription to the run's lines is no tap: nothing said");
  check(/time starts when a page is connected \(or a Foxglove client subscribes\)/.test(run.out()), "the run said it waits");

  // 3. simulated time, never backwards, up to the end (1 s)
  check(times.length > 5, `Time messages: ${times.length}`);
  check(times.every((t, i) => i === 0 || t >= times[i - 1]), `Time never goes backwards: ${show(times.slice(0, 20))}`);
  const last = times.length ? Number(times[times.length - 1]) : 0;
  check(last >= 0.9e9 && last < 5e9, `the last Time is the run's simulated end (about 1 s): ${last} ns`);
  check(samples.length > 10 && samples.every((s) => Number(s.t) < 5e9), `samples on the simulated clock: ${samples.length}`);
  // 4. the run's lines as the recordings hold them
  const done = lines.find((l) => l.msg.path === "main" && l.msg.state === "DONE");
  check(done && /^main: DONE/.test(done.msg.line) && Number(done.t) >= 0.9e9 && Number(done.t) < 5e9,
        `the root's DONE on /dca/events at its simulated time: ${show(done)} (of ${lines.length} lines)`);
  check(lines.every((l) => typeof l.msg.line === "string" && "path" in l.msg && "state" in l.msg),
        `every line {line, path, state}: ${show(lines.slice(0, 3))}`);
  // 5. the connection graph
  const pub = graph?.publishedTopics?.find((p) => p.name === "/main/one/Out");
  const sub = graph?.subscribedTopics?.find((p) => p.name === "/main/one/Out");
  check(pub && show(pub.publisherIds) === show(["main.one"]), `/main/one/Out published by main.one: ${show(pub)}`);
  check(sub && show(sub.subscriberIds) === show(["main.scale"]), `/main/one/Out read by main.scale: ${show(sub)}`);
  check(graph && Array.isArray(graph.advertisedServices) && Array.isArray(graph.removedTopics), `the update's lists: ${show(graph)}`);
  client.close();
  console.log(`foxglove parity: ${times.length} Time messages up to ${last} ns, ${lines.length} lines on /dca/events, ` +
              `${samples.length} samples, ${graph?.publishedTopics?.length} published topics in the graph`);
} catch (e) {
  failures.push(e.message);
  run.kill();
}
run.report(failures);
