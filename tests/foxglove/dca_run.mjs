// A `dca run` for the Foxglove tests: its output kept, waited for by pattern, its exit awaited.
//   const run = startRun(DCA, ARGS)   run.said(RE, MS, WHAT) --> the match (rejects after MS)   run.ended --> code
//   run.out()   run.kill()            deadline(MS, WHAT): a promise rejected after MS
//   run.report(failures)              the run's last lines and each failure, exit 1 (nothing when none)
import { spawn } from "node:child_process";

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
