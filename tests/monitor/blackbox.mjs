// The monitor's black box button in a real browser (Debian's chromium, headless):
//   node blackbox.mjs DCA_EXE SOURCE_DIR OUT_DIR
// 1. `dca run WAIT.dca --sim mock:worlds/ur10/ur10.urdf --realtime --monitor --monitor-wait --record box.mcap
//    --blackbox 0.2,0.1`: the page shows the button; a click is answered with the trigger's tick, and the run's
//    summary names box-1.mcap `monitor: page` at that tick. The REPL's event then ends the run.
// 2. The same run without --blackbox: the page shows no button.
// Every wait is for something the page or the run says, with a deadline.
import { mkdirSync, rmSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { spawn } from 'node:child_process';
import { check, childEnv, inChromium, startMonitor, until } from './driver.mjs';

const [exe, src, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });
const world = 'mock:' + join(src, 'worlds/ur10/ur10.urdf');
const system = join(out, 'wait.dca');
// (a leaf ticking every 10 ms: the world answers requests between its rounds; the Timer is ended by the REPL's
// event, once the page has had its say: a page in a loaded machine may take seconds to come up)
writeFileSync(system, 'process main() {\n  instantiated_processes {\n    stop instof Timer("arm", 600);\n' +
  '    ramp instof Counter("arm", 0.01);\n  }\n  internal_event_actions { stop # ramp }\n}\n');
const box = join(out, 'box.mcap');
rmSync(join(out, 'box-1.mcap'), { force: true });

// Runs the system with `args`, opens its page, calls fn(page); --> the run's exit code and output.
async function withPage(browser, args, fn) {
  const run = await startMonitor(exe, ['run', system, '--sim', world, '--monitor', '--monitor-wait', ...args]);
  try {
    const page = await browser.newPage();
    await page.goto(run.url);
    check(await until(page, () => document.body.dataset.mode === 'live', 30), 'the page is live');
    await fn(page);
    // the run's end: the Timer's done, through the console the run printed (dca repl)
    const [, daemon, key] = run.output().match(/console: dca repl main --daemon (\S+) --key (\S+)/);
    const repl = spawn(exe, ['repl', 'main', '--daemon', daemon, '--key', key], { stdio: ['pipe', 'ignore', 'ignore'],
      env: childEnv });
    repl.stdin.end('event("stop", "done", 1)\n');
    const code = await Promise.race([run.exited, new Promise((r) => setTimeout(() => r('timeout'), 60000))]);
    await page.close();
    return { code, text: run.output() };
  } finally {
    run.p.kill('SIGTERM');
  }
}

process.exit(await inChromium(async (browser) => {
  let t = null;
  const r = await withPage(browser, ['--realtime', '--record', box, '--blackbox', '0.2,0.1'], async (page) => {
    check(await page.evaluate(() => !document.getElementById('blackbox').hidden), 'the button is shown');
    // the world is up once the tree runs in its time, and that time has started (--monitor-wait)
    check(await until(page, () => document.getElementById('lines').textContent.includes('main.ramp: running') &&
      Number(document.getElementById('clock').textContent) > 0.1, 30), 'the run is running');
    // (a click on the element itself: the header's clock moves the button as the run's time grows)
    await page.$eval('#blackbox', (b) => b.click());
    const reply = await until(page, () => {
      const m = document.getElementById('reply').textContent.match(/^ok: black box triggered \(monitor: page\) at ([0-9.]+) s$/);
      return m && m[1];
    }, 10);
    const said = await page.evaluate(() => document.getElementById('reply').textContent);
    check(reply !== null, `the page says the trigger's tick: ${said}`);
    t = reply;
  });
  check(r.code === 0, `the run ended DONE (exit ${r.code})`);
  check(t !== null && r.text.includes(`box-1.mcap: monitor: page at ${t} s`),
    `the summary names box-1.mcap's trigger at ${t} s:\n${t ? r.text.split('\n').filter((l) => /recorded|black box/.test(l)).join('\n') : r.text}`);
  const none = await withPage(browser, [], async (page) => {
    check(await page.evaluate(() => document.getElementById('blackbox').hidden), 'without --blackbox: no button');
  });
  check(none.code === 0, `the run without a black box ended DONE (exit ${none.code})`);
}));
