// The web monitor's benchmarks (BENCHMARKS.md: RESULT lines on stdout, the rest on stderr), run by
// tests/bench/monitor_bench.lua:
//   node bench.mjs rtf DCA SOURCE_DIR ROUNDS   the door run in simulated time, alternated (A B C A B C ...):
//       A no monitor, B --monitor without a page, C --monitor with a headless WebSocket client reading everything
//       (the snapshot, every delta, the samples of /world/door/angle), C' the same also plotting a port (tapped: one more
//       data link in lock-step, host/net/tap.h), D --monitor with a page in headless
//       chromium (the tree, the expressions, the timeline and a live plot of /world/door/angle; chromium's rendering
//       shares the machine's cores with the run). rtf = 20.06 simulated s / the wall time from
//       the root's first step running to its DONE, as both lines reach this script (the same measure for all).
//   node bench.mjs big DCA SOURCE_DIR ROUNDS   the 1,000-leaf / 100-group system (supervisor_bench's generated
//       shape) run by the real supervisor engine on the in-memory cluster (big_system.lua), paced to wall time,
//       a sample topic at 1 kHz: the page's frame intervals while it runs, beside the same page idle.
import { spawn } from 'node:child_process';
import { join } from 'node:path';
import puppeteer from 'puppeteer-core';
import WebSocket from 'ws';  // puppeteer-core's own WebSocket client (in the lockfile)

// dca's children stop when the process that started them is gone (DCA_PARENT_PID, host/spawn.h): this script's
// own children must not inherit the variable meant for this script.
const childEnv = { ...process.env };
delete childEnv.DCA_PARENT_PID;

const [what, exe, src, roundsArg] = process.argv.slice(2);
const rounds = Number(roundsArg) || 2;
const door = join(src, 'worlds/door/systems/door_open.dca');
const log = (...a) => process.stderr.write(a.join(' ') + '\n');

function stats(xs) {
  const s = [...xs].sort((a, b) => a - b);
  const q = (p) => s[Math.max(0, Math.min(s.length - 1, Math.ceil(p * s.length) - 1))];
  return `n=${s.length} p50_us=${q(0.5).toFixed(0)} p99_us=${q(0.99).toFixed(0)} p999_us=${q(0.999).toFixed(0)} ` +
    `max_us=${s[s.length - 1].toFixed(0)}`;
}

// Runs `dca ARGS`; calls onLine(line, ms) for each line of its output; resolves with the exit code.
function run(args, onLine) {
  const p = spawn(exe, args, { stdio: ['ignore', 'pipe', 'pipe'], env: childEnv });
  let buf = '';
  const feed = (c) => {
    buf += c;
    let i;
    while ((i = buf.indexOf('\n')) >= 0) { onLine(buf.slice(0, i), performance.now()); buf = buf.slice(i + 1); }
  };
  p.stdout.on('data', feed);
  p.stderr.on('data', feed);
  return { p, done: new Promise((resolve) => p.on('exit', resolve)) };
}

async function doorOnce(browser, variant) {
  const args = ['run', door, '--sim', 'door'];
  if (variant !== 'no_monitor') args.push('--monitor', '--as-fast-as-possible');
  if (variant === 'browser' || variant.startsWith('ws_reader')) args.push('--monitor-wait');
  let t0 = null, t1 = null, url = null, page = null, summary = null;
  const r = run(args, (line, ms) => {
    if (t0 === null && /main\.dooropensyst: running/.test(line)) t0 = ms;
    if (/main: DONE/.test(line)) t1 = ms;
    const m = line.match(/monitor: (http:\/\/\S+)/);
    if (m) url = m[1];
    const s = line.match(/simulated ([\d.]+) s in ([\d.]+) s of wall-clock/);
    if (s) summary = Number(s[1]) / Number(s[2]);
  });
  if (variant === 'browser') {
    for (let i = 0; !url; i++) {
      if (i > 6000) throw new Error('no monitor address within 60 s');
      await new Promise((res) => setTimeout(res, 10));
    }
    page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 1000 });
    await page.goto(url);
    await page.waitForFunction((n) => {  // chosen in the plot's topic tree (page/plot.js)
      const row = [...document.querySelectorAll('#plot-topics .ptopic')].find((r) => r.dataset.name === n);
      if (row) row.click();
      return !!row;
    }, { timeout: 30000, polling: 20 }, '/world/door/angle');
  }
  let reader = null;
  if (variant.startsWith('ws_reader')) {
    while (!url) await new Promise((res) => setTimeout(res, 10));
    reader = read(url, variant === 'ws_reader_port');
  }
  const code = await r.done;
  const samples = page ? await page.evaluate(() => Number(document.getElementById('plot').dataset.samples))
    : (reader ? reader.samples : 0);
  if (page) await page.close();
  if (code !== 0 || t0 === null || t1 === null) throw new Error(`door run (${variant}) failed: exit ${code}`);
  return { wall_ms: t1 - t0, rtf: 20.06 / ((t1 - t0) / 1000), summary, samples };
}

// A WebSocket client of dca.monitor.v1 that reads everything and subscribes to the world's door signal (and with
// `port`, to a port's samples).
function read(url, port) {
  const u = new URL(url);
  const ws = new WebSocket(`ws://${u.host}/ws?token=${u.searchParams.get('token')}`, 'dca.monitor.v1');
  const st = { samples: 0, bytes: 0 };
  const want = port ? ['/world/door/angle', '/main/dooropensyst/motionctrl/redundancy/BaseVel'] : ['/world/door/angle'];
  const subscribe = (topics) => {
    for (const t of Array.isArray(topics) ? topics : []) if (want.includes(t.name)) ws.send(JSON.stringify({ type: 'subscribe', topic: t.id, rate: 200 }));
  };
  ws.on('message', (data) => {
    st.bytes += data.length;
    const m = JSON.parse(data);
    if (m.type === 'samples') st.samples += m.rows.length;
    if (m.topics) subscribe(m.topics);
  });
  ws.on('error', () => {});
  return st;
}

async function rtf(browser) {
  const variants = ['no_monitor', 'monitor_no_page', 'ws_reader', 'ws_reader_port', 'browser'];
  const res = Object.fromEntries(variants.map((v) => [v, []]));
  for (let i = 0; i < rounds; i++) {
    for (const v of variants) {
      const r = await doorOnce(browser, v);
      log(`round ${i + 1} ${v}: rtf ${r.rtf.toFixed(2)} (summary ${r.summary?.toFixed(2)}), plot samples ${r.samples}`);
      res[v].push(r);
    }
  }
  for (const v of variants) {
    const rs = res[v];
    const med = [...rs.map((r) => r.rtf)].sort((a, b) => a - b)[Math.floor((rs.length - 1) / 2)];
    const extra = v === 'browser' || v.startsWith('ws_reader') ? ` samples_received=${Math.min(...rs.map((r) => r.samples))}` : '';
    console.log(`RESULT bench=monitor_door_rtf variant=${v} ${stats(rs.map((r) => r.wall_ms * 1000))} ` +
      `rtf=${med.toFixed(2)}${extra}`);
  }
}

// Frame intervals (us) of the page over `ms` milliseconds.
async function frames(page, ms) {
  return page.evaluate((d) => new Promise((resolve) => {
    const out = [];
    let last = performance.now();
    const end = last + d;
    const tick = (now) => {
      out.push((now - last) * 1000);
      last = now;
      if (now < end) requestAnimationFrame(tick); else resolve(out);
    };
    requestAnimationFrame(tick);
  }), ms);
}

async function big(browser) {
  let url = null, phase = 'idle';
  const r = run(['lua', join(src, 'tests/monitor/big_system.lua'), String(rounds)], (line) => {
    const m = line.match(/monitor: (http:\/\/\S+)/);
    if (m) url = m[1];
    const p = line.match(/^phase (\w+)/);
    if (p) phase = p[1];
    if (!m && !p) log(line);
  });
  const deadline = performance.now() + 60000;
  while (!url) {
    if (performance.now() > deadline) throw new Error('big_system.lua printed no monitor address within 60 s');
    await new Promise((res) => setTimeout(res, 10));
  }
  const page = await browser.newPage();
  await page.setViewport({ width: 1400, height: 1000 });
  const t0 = performance.now();
  await page.goto(url);
  await page.waitForFunction(() => window.dcaMonitor && window.dcaMonitor.nodes.size >= 1101, { timeout: 60000, polling: 20 });
  const shown_ms = performance.now() - t0;
  await page.waitForFunction((n) => {  // chosen in the plot's topic tree (page/plot.js)
    const row = [...document.querySelectorAll('#plot-topics .ptopic')].find((r) => r.dataset.name === n);
    if (row) row.click();
    return !!row;
  }, { timeout: 30000, polling: 20 }, '/bench/signal');
  const res = { idle: [], busy: [] };
  for (let i = 0; i < rounds; i++) {
    for (const want of ['idle', 'busy']) {
      while (phase !== want) await new Promise((res) => setTimeout(res, 20));
      res[want].push(...await frames(page, 4000));
    }
  }
  const rows = await page.evaluate(() => document.querySelectorAll('.row').length);
  const events = await page.evaluate(() => window.dcaMonitor.events.length);
  r.p.kill('SIGTERM');
  await r.done;
  console.log(`RESULT bench=monitor_page_frame variant=1000leaves_idle ${stats(res.idle)} tree_shown_ms=${shown_ms.toFixed(0)}`);
  console.log(`RESULT bench=monitor_page_frame variant=1000leaves_running ${stats(res.busy)} rows_in_page=${rows} events=${events}`);
}

const browser = await puppeteer.launch({
  executablePath: process.env.DCA_CHROMIUM || '/usr/bin/chromium', headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage', '--no-first-run'],
});
try {
  if (what === 'big') await big(browser); else await rtf(browser);
} finally {
  await browser.close();
}
