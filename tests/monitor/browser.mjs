// The web monitor in a real browser: Debian's chromium, headless, driven by puppeteer-core (no browser download).
//   node browser.mjs live DCA_EXE SOURCE_DIR OUT_DIR     a door run in simulated time, watched live
//   node browser.mjs replay DCA_EXE SOURCE_DIR OUT_DIR   a recorded door run, replayed by `dca monitor FILE.mcap`
//   node browser.mjs attach DCA_EXE SOURCE_DIR OUT_DIR   `dca monitor PATH --daemon ADDR --key FILE` on a door run
//   node browser.mjs faults DCA_EXE SOURCE_DIR OUT_DIR   restart counts and faults (test_strategy.dca, wall clock),
//                                                        then a real-time thread's figures (rt { }, wall clock)
// Every wait is for something the page shows, with a deadline; the screenshots go to OUT_DIR.
import { spawn } from 'node:child_process';
import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { check, childEnv, inBrowser, record, seek, startMonitor, until } from './driver.mjs';

const [mode, exe, src, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });
const door = join(src, 'worlds/door/systems/door_open.dca');

// Starts `dca ARGS` and resolves with the process and the monitor's URL once it is printed (within 60 s).
const start = (args) => startMonitor(exe, args);

// Chooses the signal `name` alone for the plot once the page offers it (its topic tree: page/plot.js).
async function pick(page, name) {
  await page.click('#plot-clear');
  const ok = await until(page, (n) => {
    const row = [...document.querySelectorAll('#plot-topics .ptopic')].find((r) => r.dataset.name === n);
    if (row) row.click();
    return !!row;
  }, 20, name);
  check(ok, `the page offers the signal ${name}`);
}

// A key holder's token (`dca monitor --token --key FILE`, the run's key) opens the page too.
async function keyToken(browser, run) {
  let key = null;
  for (let i = 0; i < 200 && !key; i++) {
    key = run.output().match(/--key (\S+)/)?.[1];
    if (!key) await new Promise((r) => setTimeout(r, 50));
  }
  const token = await new Promise((resolve) => {
    const p = spawn(exe, ['monitor', '--token', '--key', key], { stdio: ['ignore', 'pipe', 'inherit'], env: childEnv });
    let out = '';
    p.stdout.on('data', (c) => { out += c; });
    p.on('exit', () => resolve(out.trim()));
  });
  const page = await browser.newPage();
  await page.goto(run.url.replace(/\?token=.*$/, `?token=${token}`));
  const shown = await until(page, () => document.body.dataset.connected === 'yes' &&
    document.querySelectorAll('.row').length > 0, 20);
  check(/^[0-9a-f]{32}$/.test(token) && shown, `the cluster key's token (dca monitor --token) opens the page (${token})`);
  await page.close();
}

async function noToken(browser, url) {
  const bare = url.replace(/\?token=.*$/, '');
  for (const [what, u] of [['no token', bare], ['a wrong token', bare + '?token=0123456789abcdef0123456789abcdef']]) {
    const page = await browser.newPage();
    await page.goto(u);
    const denied = await until(page, () => document.body.dataset.access === 'denied', 10);
    const shown = await page.evaluate(() => ({ rows: document.querySelectorAll('.row').length,
      main: !document.getElementById('main').hidden }));
    check(denied && shown.rows === 0 && !shown.main, `with ${what} the page shows nothing (rows ${shown.rows})`);
    await page.close();
  }
}

// Checks that the monitor at url shows nothing without its token, then opens it in a new 1400x1000 page.
async function openMonitor(browser, url) {
  await noToken(browser, url);
  const page = await browser.newPage();
  await page.setViewport({ width: 1400, height: 1000 });
  await page.goto(url);
  return page;
}

async function live(browser) {
  const run = await start(['run', door, '--sim', 'door', '--realtime', '--monitor', '--monitor-wait']);
  try {
    const page = await openMonitor(browser, run.url);
    const rows = await until(page, () => document.querySelectorAll('.row').length >= 28 &&
      [...document.querySelectorAll('.row')].map((r) => [r.dataset.path, r.dataset.host]), 20);
    const instances = (rows || []).filter(([p]) => p !== 'main');
    check(instances.length === 27, `the tree shows 27 instances below main (${instances.length})`);
    check(instances.every(([, h]) => ['vision', 'platform', 'manipulation'].includes(h)),
      'every instance shows its host (vision, platform or manipulation)');
    const sel = '.row[data-path="main.dooropensyst.distdetect"]';
    const ran = await until(page, (s) => document.querySelector(s)?.dataset.state === 'running', 20, sel);
    check(ran, 'distdetect is shown running');
    const hi = await until(page, () => document.querySelector(
      '.leaf.running[data-path="main.dooropensyst.distdetect"]') !== null, 10);
    check(hi, 'the expression view highlights the running step (distdetect)');
    await pick(page, '/world/door/angle');
    const ended = await until(page, (s) => document.querySelector(s)?.dataset.state === 'done', 30, sel);
    check(ended, 'distdetect is shown done when its step ends');
    const next = await until(page, () => document.querySelector('.leaf.running[data-path="main.dooropensyst.hit"]') !== null ||
      document.querySelector('.leaf.running[data-path="main.dooropensyst.approach"]') !== null, 20);
    check(next, 'the highlight moves to the next step (approach # hit)');
    const n = await until(page, () => Number(document.getElementById('plot').dataset.samples) >= 20 &&
      Number(document.getElementById('plot').dataset.samples), 20);
    check(n >= 20, `the live plot of /world/door/angle receives samples (${n})`);
    // its unit as the world's manifest writes it (worlds/door/world.h: door.angle in rad), not degrees
    const legend = await page.evaluate(() => document.getElementById('legend').textContent);
    check(legend === 'door.angle[0] rad', `the door's angle in the manifest's unit (${legend})`);
    // a port: its samples tapped (taps, host/net/tap.h) into the server's live samples once the page subscribes
    const port = '/main/dooropensyst/motionctrl/redundancy/BaseVel';
    await pick(page, port);
    const k = await until(page, () => Number(document.getElementById('plot').dataset.samples) >= 20 &&
      Number(document.getElementById('plot').dataset.samples), 20);
    check(k >= 20, `the live plot of the port ${port} receives samples (${k})`);
    const tl = await page.evaluate(() => Number(document.getElementById('timeline').dataset.rows || 0));
    check(tl >= 10, `the timeline shows the steps so far (${tl} rows)`);
    const cfg = await page.evaluate(() => document.querySelectorAll('#config tr').length);
    check(cfg >= 5, `the configuration repository is shown (${cfg} keys)`);
    await configFromThePage(page);
    await page.screenshot({ path: join(out, 'monitor_live.png') });
    console.log(`screenshot: ${join(out, 'monitor_live.png')}`);
    await keyToken(browser, run);
  } finally {
    run.p.kill('SIGTERM');
  }
}

// A value set from the page goes through the console's config.set; the repository's change comes back as a
// config.watch line and is shown.
async function configFromThePage(page) {
  await page.type('#config-key', 'door.hit_force');
  await page.type('#config-value', '7.5');
  await page.click('#config-set button');
  const shown = await until(page, () => document.querySelector('#config tr[data-key="door.hit_force"] td:nth-child(2)')
    ?.textContent === '7.5', 15);
  check(shown, 'a configuration value set from the page is written and shown as it changes');
}

// The robot's emergency stop from the page's buttons (docs/safety.md): pressed, the root's line names the monitor
// as its source and a second press is no new one; released, the root says so.
async function estopFromThePage(page) {
  const said = (re) => until(page, (r) => new RegExp(r).test(document.getElementById('lines').textContent), 20, re);
  await page.click('#estop');
  check(await said('main: emergency stop pressed by monitor at [0-9.]+ s'),
    'the page\'s emergency stop presses the robot\'s stop: the root says it with its source');
  check(await until(page, () => /^ok: emergency stop pressed at/.test(document.getElementById('reply').textContent), 10),
    'the page shows the answer');
  check(await until(page, () => !document.getElementById('estop-state').hidden &&
    /^EMERGENCY STOP \(monitor, [0-9.]+ s\)$/.test(document.getElementById('estop-state').textContent), 10),
    'the header shows the stop latched, with its source');
  await page.click('#estop');
  check(await until(page, () => /^ok: emergency stop already pressed by monitor/.test(
    document.getElementById('reply').textContent), 10), 'a second press is no new one');
  await page.click('#estop-release');
  check(await said('main: emergency stop released by monitor at [0-9.]+ s'), 'the page releases it (by its name)');
  check(await until(page, () => document.getElementById('estop-state').hidden &&
    document.body.dataset.estop === 'released', 10), 'the header no longer shows it');
}

// `dca monitor PATH --daemon ADDR --key FILE` attached to a running system through its root's console.
async function attach(browser) {
  const run = spawn(exe, ['run', door, '--sim', 'door', '--realtime'], { stdio: ['ignore', 'pipe', 'pipe'], env: childEnv });
  let text = '';
  const consoleLine = await new Promise((resolve, reject) => {
    const deadline = setTimeout(() => reject(new Error(`no console line within 60 s:\n${text}`)), 60000);
    run.stdout.on('data', (c) => {
      text += c;
      const m = text.match(/console: dca repl (\S+) --daemon (\S+) --key (\S+)/);
      if (m) { clearTimeout(deadline); resolve(m); }
    });
  });
  const mon = await start(['monitor', consoleLine[1], '--daemon', consoleLine[2], '--key', consoleLine[3]]);
  try {
    const page = await openMonitor(browser, mon.url);
    const rows = await until(page, () => document.querySelectorAll('.row').length >= 28 &&
      [...document.querySelectorAll('.row')].filter((r) => r.dataset.host).length, 20);
    check(rows >= 28, `the attached monitor shows the tree with hosts (${rows} rows)`);
    const sel = '.row[data-path="main.dooropensyst.hit"]';
    const ran = await until(page, (s) => document.querySelector(s)?.dataset.state === 'running', 30, sel);
    const ended = ran && await until(page, (s) => document.querySelector(s)?.dataset.state === 'done', 30, sel);
    check(ran && ended, 'the attached monitor follows the states (hit running, then done)');
    await pick(page, '/world/door/angle');
    const n = await until(page, () => Number(document.getElementById('plot').dataset.samples) >= 10 &&
      Number(document.getElementById('plot').dataset.samples), 20);
    check(n >= 10, `the attached monitor plots the world's /world/door/angle (${n} samples)`);
    // a port: tapped (the root's console request `tap`) into the attached process's own tap point
    const port = '/main/dooropensyst/motionctrl/redundancy/BaseVel';
    await pick(page, port);
    const k = await until(page, () => Number(document.getElementById('plot').dataset.samples) >= 20 &&
      Number(document.getElementById('plot').dataset.samples), 20);
    check(k >= 20, `the attached monitor plots the port ${port} live (${k} samples)`);
    await configFromThePage(page);
    await estopFromThePage(page);
    await page.screenshot({ path: join(out, 'monitor_attach.png') });
    const exit = new Promise((resolve) => run.on('exit', resolve));
    await page.click('#abort-all');
    const aborted = await until(page, () => document.querySelector('.row[data-path="main"]')?.dataset.state === 'aborted', 20);
    check(aborted, 'the page aborts the run (ABORTED injected into the running step, as abort(path) in the REPL): main is shown aborted');
    const code = await Promise.race([exit, new Promise((r) => setTimeout(() => r('still running'), 20000))]);
    check(code === 1, `the run ends ABORTED (exit ${code})`);
  } finally {
    mon.p.kill('SIGTERM');
    run.kill('SIGTERM');
  }
}

// Clicks the element `sel` from inside the page, in one step (the tree's rows are redrawn as the run goes: a
// row found, then hovered and clicked from here, may have been replaced in between).
async function clickIn(page, sel) {
  const ok = await page.evaluate((s) => { const b = document.querySelector(s); if (b) b.click(); return !!b; }, sel);
  check(ok, `clicked ${sel}`);
}

// Restart counts and faults: test_strategy.dca (one_for_one, restart on crash) with the monitor. A restart from
// the page, then a crash of the restarted process (SIGSEGV to the pid its line names): the row counts both
// restarts and shows the crash's reason; an abort from the page ends the run ABORTED with its reason shown.
async function faults(browser) {
  const strategy = join(src, 'scripts/systems/test_strategy.dca');
  const run = await start(['run', strategy, '--monitor']);
  let pid = null;
  const exit = new Promise((resolve) => run.p.on('exit', resolve));
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 800 });
    await page.goto(run.url);
    const gain = '.row[data-path="main.line.gain"]';
    check(await until(page, (s) => document.querySelector(s)?.dataset.state === 'running', 20, gain), 'gain is shown running');
    check(await until(page, () => [...document.querySelectorAll('.row')].every((r) => /^h[12]$/.test(r.dataset.host)), 10),
      'every process of test_strategy shows its host (h1, h2)');
    await clickIn(page, `${gain} button[data-cmd="restart"]`);
    check(await until(page, (s) => document.querySelector(`${s} .restarts`)?.textContent === '↻1', 20, gain),
      'a restart from the page is counted on the row (↻1)');
    for (let i = 0; i < 200 && !pid; i++) {
      const m = run.output().match(/main\.line\.gain: restarted \(pid (\d+)\)/);
      if (m) pid = Number(m[1]); else await new Promise((r) => setTimeout(r, 50));
    }
    check(pid, `the restarted process's pid is in its line (${pid})`);
    if (pid) process.kill(pid, 'SIGSEGV');
    const crashed = await until(page, (s) => {
      const r = document.querySelector(s);
      return r && r.querySelector('.restarts').textContent === '↻2' && r.querySelector('.fault').textContent;
    }, 20, gain);
    check(crashed && /signal|SEGV/i.test(crashed), `the crash is restarted by its policy, counted (↻2), its fault shown (${crashed})`);
    if (!(crashed && /signal|SEGV/i.test(crashed))) console.log(run.output().split('\n').filter((l) => /gain|ERROR|Sanitizer|SUMMARY/.test(l)).slice(-20).join('\n'));
    const count = '.row[data-path="main.line.count"]';
    await clickIn(page, `${count} button[data-cmd="abort"]`);
    const fault = await until(page, (s) => document.querySelector(`${s} .fault`)?.textContent, 20, count);
    const main = await until(page, () => document.querySelector('.row[data-path="main"]')?.dataset.state === 'aborted', 20);
    check(fault === 'aborted from the monitor' && main,
      `an abort from the page: count's fault shown (${fault}), the run aborted`);
    if (!(fault === 'aborted from the monitor' && main)) {
      console.log(run.output().split('\n').filter((l) => /count|line:|main:|ERROR|Sanitizer/.test(l)).slice(-12).join('\n'));
    }
    await page.screenshot({ path: join(out, 'monitor_faults.png') });
    const code = await Promise.race([exit, new Promise((r) => setTimeout(() => r('still running'), 20000))]);
    check(code === 1, `the run ends ABORTED (exit ${code})`);
  } finally {
    run.p.kill('SIGTERM');
  }
  await realTime(browser);
}

// Leaves on a real-time thread (rt { }, wall clock; without the privilege, the default scheduler): the page's
// Real time table shows each one's runs, period, wake latency and execution time.
async function realTime(browser) {
  const file = join(out, 'rt_line.dca');
  writeFileSync(file, `process main() {
  rt { priority 10; }
  instantiated_processes { src instof Constant("h1", 0.001, 1); gain instof Gain("h1", 2, 0);
                           count instof Counter("h1", 0.01, 0); }
  internal_connections(src, run) { src, Out -> gain, In; }
  internal_event_actions { count # (src[run], gain) }
}
`);
  const run = await start(['run', file, '--monitor']);
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 800 });
    await page.goto(run.url);
    const src = '#rt tr[data-path="main.src"]';
    const runs = await until(page, (s) => Number(document.querySelector(`${s} .runs`)?.textContent) > 100 &&
      Number(document.querySelector(`${s} .runs`).textContent), 20, src);
    check(runs > 100 && await page.evaluate(() => !document.getElementById('rt-pane').hidden),
      `the Real time table shows src's runs on its real-time thread (${runs})`);
    const row = await page.evaluate((s) => [...document.querySelectorAll(`${s} td`)].map((td) => td.textContent), src);
    check(row[2] === '1.000 ms' && /^\d+ us \/ \d+ us \/ [\d.]+ (us|ms)$/.test(row[3]) && /us/.test(row[4]),
      `with its period, wake latency and execution time (${row.join(' | ')})`);
    const paths = await page.evaluate(() => [...document.querySelectorAll('#rt tbody tr')].map((r) => r.dataset.path));
    check(paths.join() === 'main.src,main.gain,main.count', `one row per leaf (${paths.join()})`);
    await page.screenshot({ path: join(out, 'monitor_real_time.png') });
  } finally {
    run.p.kill('SIGTERM');
  }
}

async function replay(browser) {
  const rec = join(out, 'door.mcap');
  const code = await record(exe, [door, '--sim', 'door'], rec);
  check(code === 0, `the door run recorded ${rec} (exit ${code})`);
  const mon = await start(['monitor', rec, '--system', door]);
  try {
    const page = await openMonitor(browser, mon.url);
    const ready = await until(page, () => document.body.dataset.mode === 'replay' &&
      document.querySelectorAll('.row').length >= 28, 20);
    check(ready, 'the recording is shown in replay mode with its tree');
    const at = async (t) => {
      await seek(page, t);
      return page.evaluate(() => ({
        distdetect: document.querySelector('.row[data-path="main.dooropensyst.distdetect"]')?.dataset.state,
        dooropen: document.querySelector('.row[data-path="main.dooropensyst.dooropen"]')?.dataset.state,
        clock: document.getElementById('clock').textContent,
      }));
    };
    const early = await at(1.0);
    const late = await at(15.0);
    check(early.distdetect === 'running' && late.distdetect === 'done',
      `the slider moves the view: distdetect ${early.distdetect} at 1 s, ${late.distdetect} at 15 s`);
    check(late.dooropen === 'running', `dooropen is running at 15 s (${late.dooropen})`);
    await pick(page, '/world/door/angle');
    const n = await until(page, () => Number(document.getElementById('plot').dataset.samples), 10);
    check(n > 100, `the recorded /world/door/angle signal is plotted (${n} samples)`);
    const port = '/main/dooropensyst/motionctrl/redundancy/BaseVel';
    await pick(page, port);
    const k = await until(page, () => Number(document.getElementById('plot').dataset.samples) > 100 &&
      document.getElementById('legend').textContent, 10);
    check(k && k.includes('redundancy.BaseVel[0] m/s') && k.includes('redundancy.BaseVel[2] rad/s'),
      `the recorded port ${port} is plotted with its fields and their units from the manifest (${k})`);
    await page.click('#play');
    const moved = await until(page, () => Number(document.getElementById('clock').textContent) > 15.2, 10);
    check(moved, 'play advances the time');
    await page.screenshot({ path: join(out, 'monitor_replay.png') });
    console.log(`screenshot: ${join(out, 'monitor_replay.png')}`);
  } finally {
    mon.p.kill('SIGTERM');
  }
}

await inBrowser(async (browser) => {
  if (mode === 'replay') await replay(browser);
  else if (mode === 'attach') await attach(browser);
  else if (mode === 'faults') await faults(browser);
  else await live(browser);
});
