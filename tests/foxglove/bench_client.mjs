// The Foxglove client of tests/bench/foxglove_live_bench.lua: runs `dca run SYSTEM --sim door --monitor
// --monitor-wait [ARGS...]`, connects with @foxglove/ws-protocol, subscribes to every channel whose topic starts
// with PREFIX ("" = none: connected, subscribed to nothing), starts time by opening the monitor's page protocol
// once every tap is made, and prints the run's output followed by one line
//   foxglove_client: channels=N subscribed=S messages=M bytes=B
//   node bench_client.mjs DCA SYSTEM PREFIX [ARGS...]
import { spawn } from "node:child_process";
import foxglove from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = foxglove;
const [dca, system, prefix, ...args] = process.argv.slice(2);
const run = spawn(dca, ["run", system, "--sim", "door", "--monitor", "--monitor-wait", "--as-fast-as-possible", ...args],
                  { stdio: ["ignore", "pipe", "pipe"] });
let out = "", started = false, channels = 0, subscribed = 0, messages = 0, bytes = 0, page;
// (every tap made before time starts, --monitor-taps all: "live: tapped N of N ..." once, counted as all of them)
const taps = () => (/live: tapped \d+ of \d+ ports/.test(out) ? Infinity : (out.match(/live: tapped /g) ?? []).length);
const startTime = (url) => { page = new WebSocket(url, ["dca.monitor.v1"]); page.on("error", () => {}); };
const connect = (url) => {
  const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  client.on("error", () => {});
  client.on("message", ({ data }) => { messages++; bytes += data.byteLength; });
  client.on("advertise", (list) => {
    channels += list.length;
    for (const c of list) if (prefix !== "" && c.topic.startsWith(prefix)) { client.subscribe(c.id); subscribed++; }
    // time starts once the taps are made (each says "live: tapped"), or at once without subscriptions
    const wait = setInterval(() => {
      if (taps() < subscribed) return;
      clearInterval(wait);
      startTime(url);
    }, 5);
  });
};
const onText = (d) => {
  out += d;
  const m = out.match(/foxglove: (ws:\/\/\S+)/);
  if (m && !started) { started = true; connect(m[1]); }
};
run.stdout.on("data", onText);
run.stderr.on("data", onText);
run.on("exit", (code) => {
  process.stdout.write(out);
  console.log(`foxglove_client: channels=${channels} subscribed=${subscribed} messages=${messages} bytes=${bytes}`);
  page?.close();
  process.exit(code ?? 1);
});
