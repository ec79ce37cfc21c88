// Foxglove's parameters (@foxglove/ws-protocol's FoxgloveClient on ws): the configuration repository's keys of a
// running system (`dca run scripts/systems/test_live.dca --sim mock:worlds/ur10/ur10.urdf --monitor --monitor-wait`):
//   node params.mjs DCA SOURCE_DIR
// 1. serverInfo has the capability `parameters`.
// 2. getParameters with no names answers every key with its value (the system's defaults file), with names only
//    those (a name that is no key is left out), each with the request's id.
// 3. setParameters test.gain = 3 answers parameterValues with the new value and the request's id; the key reaches
//    the running Gain, whose k is live: dca run says "main.scale: k = 3 (live)"; getParameters then reads 3.
// 4. Malformed requests (parameters not an array, a parameter without a value, names that are no strings) are
//    each answered with a status (level 2); the connection stays and answers the next request.
// 5. The page starts time (--monitor-wait) and the run ends DONE. Exit 1 on a failure.
import { deadline, foxgloveClient, pageToEnd, startLiveRun } from "./dca_run.mjs";

const [dca, src] = process.argv.slice(2);
const failures = [];
const check = (ok, what) => { if (!ok) failures.push(what); };
const show = (x) => JSON.stringify(x);
// parameters as "name=value" lines, sorted (the order of a parameter's fields is JSON's, not the point)
const lines = (params) => (params ?? []).map((p) => `${p.name}=${JSON.stringify(p.value)}`).sort().join(", ");

const run = startLiveRun(dca, src);
const { said } = run;

try {
  const { url, ws, client, info: serverInfo } = await foxgloveClient(run, failures);
  const info = await serverInfo;
  check(info.capabilities.includes("parameters"), `serverInfo's capabilities ${show(info.capabilities)}`);

  // the answers by id, the statuses in order
  const answers = new Map(), statuses = [];
  const waiting = new Map();
  client.on("parameterValues", (m) => { answers.set(m.id, m.parameters); waiting.get(m.id)?.(m.parameters); });
  const stat = [];
  client.on("status", (m) => { statuses.push(m); for (const w of stat.splice(0)) w(m); });
  const answer = (id) => Promise.race([answers.has(id) ? Promise.resolve(answers.get(id))
                                       : new Promise((resolve) => waiting.set(id, resolve)),
                                       deadline(20000, `parameterValues ${id}`)]);
  const nextStatus = (what) => Promise.race([new Promise((resolve) => stat.push(resolve)), deadline(20000, what)]);
  const byName = (params) => Object.fromEntries(params.map((p) => [p.name, p.value]));

  client.getParameters([], "all");
  const all = byName(await answer("all"));
  check(all["test.gain"] === 2 && all["test.period"] === 0.01, `every key: ${show(all)}`);
  client.getParameters(["test.gain", "test.nosuch"], "one");
  check(lines(await answer("one")) === "test.gain=2", `test.gain: ${show(answers.get("one"))}`);

  client.setParameters([{ name: "test.gain", value: 3 }], "set");
  check(lines(await answer("set")) === "test.gain=3", `set: ${show(answers.get("set"))}`);
  await said(/main\.scale: k = 3 \(live\)/, 20000, "the Gain's line: k = 3 (live)");
  client.getParameters(["test.gain"], "again");
  check(lines(await answer("again")) === "test.gain=3", `again: ${show(answers.get("again"))}`);

  for (const [raw, what] of [
    [{ op: "setParameters", parameters: "test.gain=4", id: "bad1" }, "parameters is a non-empty array"],
    [{ op: "setParameters", parameters: [{ name: "test.gain" }], id: "bad2" }, "each parameter needs a name and a value"],
    [{ op: "getParameters", parameterNames: [1, 2], id: "bad3" }, "parameterNames is an array of strings"],
  ]) {
    const s = nextStatus(what);
    ws.send(JSON.stringify(raw));
    const m = await s;
    check(m.level === 2 && m.message.includes(what), `${show(raw)}: status ${show(m)}`);
  }
  client.getParameters(["test.gain"], "after");
  check(lines(await answer("after")) === "test.gain=3", "the connection answers after them");
  check(!answers.has("bad1") && !answers.has("bad2") && !answers.has("bad3"), "no parameterValues for the malformed");

  await pageToEnd(url, run, failures);  // time starts (--monitor-wait)
  client.close();
  console.log(`foxglove parameters: ${Object.keys(all).length} keys, test.gain 2 -> 3 (live), ` +
              `${statuses.length} statuses for the malformed requests`);
} catch (e) {
  failures.push(e.message);
  run.kill();
}
run.report(failures);
