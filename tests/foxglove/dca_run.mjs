// A `dca run` for the Foxglove tests: its output kept, waited for by pattern, its exit awaited.
//   const run = startRun(DCA, ARGS)   run.said(RE, MS, WHAT) --> the match (rejects after MS)   run.ended --> code
//   run.out()   run.kill()            deadline(MS, WHAT): a promise rejected after MS
//   run.report(failures)              the run's last lines and each failure, exit 1 (nothing when none)
//   startLiveRun(DCA, SRC)            test_live.dca on the mock UR10 with --monitor --monitor-wait
//   const { url, ws, client, info } = await foxgloveClient(run, failures)  a client on the run's Foxglove URL;
//                                     info: its serverInfo (rejects after 20 s)
//   await pageToEnd(url, run, failures)  the monitor's page opened (time starts under --monitor-wait), the run's
//                                        end awaited: its exit code checked 0; the page closed
import { spawn } from "node:child_process";
import foxglove from "@foxglove/ws-protocol";
import WebSocket from "ws";

export const deadline = (ms, what) =>
  new Promise((_, reject) => setTimeout(() => reject(new Error(`timed out: ${what}`)), ms).unref());

export function startRun(dca, args) {
  const child = spawn(dca, args, { stdio: ["ignore", "pipe", "pipe"] });
  let out = "";
  const waiters = [];
  const onText = (chunk) => {
    out += chunk;
    for (const w of [...waiters]) if (w.re.test(out)) { waiters.splice(waiters.indexOf(w), 1); w.resolve(out.match(w.re)); }
  };
  child.stdout.on("data", onText);
  child.stderr.on("data", onText);
  return {
    ended: new Promise((resolve) => child.on("exit", (code) => resolve(code))),
    said: (re, ms, what) => Promise.race([new Promise((resolve) => { waiters.push({ re, resolve }); onText(""); }),
                                          deadline(ms, what)]),
    out: () => out,
    kill: () => child.kill("SIGTERM"),
    report: (failures) => {
      if (!failures.length) return;
      console.error(out.split("\n").slice(-30).join("\n"));
      for (const f of failures) console.error(`FAIL ${f}`);
      process.exit(1);
    },
  };
}

export async function pageToEnd(url, run, failures, ms = 120000) {
  const page = new WebSocket(url, ["dca.monitor.v1"]);
  page.on("error", (e) => failures.push(`page: ${e.message}`));
  const code = await Promise.race([run.ended, deadline(ms, "the end of the run")]);
  if (code !== 0) failures.push(`dca run ended with ${code}`);
  page.close();
}

export function startLiveRun(dca, src) {
  return startRun(dca, ["run", `${src}/scripts/systems/test_live.dca`, "--sim", `mock:${src}/worlds/ur10/ur10.urdf`,
                        "--monitor", "--monitor-wait", "--as-fast-as-possible"]);
}

export async function foxgloveClient(run, failures) {
  const [, url] = await run.said(/foxglove: (ws:\/\/\S+)/, 60000, "the foxglove line of dca run");
  const ws = new WebSocket(url, [foxglove.FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const client = new foxglove.FoxgloveClient({ ws });
  client.on("error", (e) => failures.push(`client error: ${e.message}`));
  const info = Promise.race([new Promise((resolve) => client.on("serverInfo", resolve)), deadline(20000, "serverInfo")]);
  return { url, ws, client, info };
}
