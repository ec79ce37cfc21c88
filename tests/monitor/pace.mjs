// The simulated clock on the monitor's page (docs/time.md "Pace"), in headless chromium:
//   node pace.mjs DCA_EXE SOURCE_DIR OUT_DIR
// `dca run door_open.dca --sim door --monitor --monitor-wait`: watched live, time is paced to the wall clock (1x)
// by default. The page pauses it (the header's clock is then the world's time, as the REPL's clock() says it),
// steps one tick (the clock moves by one period of the world, to the time the reply gives), sets a speed (2x),
// runs to the next event (time holds after it, a transition shown), then runs unpaced (max) to DONE. Every wait
// is for something the page shows, with a deadline; no wall-clock figure is checked. The screenshot goes to OUT_DIR.
import { mkdirSync } from 'node:fs';
import { join } from 'node:path';
import { check, inBrowser, startMonitor, until } from './driver.mjs';

const [exe, src, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });
const door = join(src, 'worlds/door/systems/door_open.dca');

// The page's reply to its last command once it matches `re` (the reply pane emptied before the command).
async function reply(page, re) {
  return until(page, (r) => {
    const m = document.getElementById('reply').textContent.match(new RegExp(r));
    return m && m.slice(1);
  }, 20, re.source);
}

async function click(page, id) {
  await page.evaluate(() => { document.getElementById('reply').textContent = ''; });
  await page.click(`#${id}`);
}

async function choose(page, value) {
  await page.evaluate(() => { document.getElementById('reply').textContent = ''; });
  await page.select('#pace-speed', value);
}

// The header's clock and the world's clock the page has, once the world's is `t` (text, 3 decimals).
const clockAt = (page, t) => until(page, (v) => document.body.dataset.clockT === v &&
  document.getElementById('clock').textContent === v && v, 20, t);

async function pace(browser) {
  const run = await startMonitor(exe, ['run', door, '--sim', 'door', '--monitor', '--monitor-wait']);
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 1000 });
    await page.goto(run.url);
    const paced = await until(page, () => !document.getElementById('pace').hidden &&
      document.body.dataset.clock === 'running' && document.body.dataset.clockSpeed, 30);
    check(paced === '1', `watched live, time runs paced at 1x by default (${paced})`);
    await until(page, () => Number(document.body.dataset.clockT) > 0.2, 30);

    await click(page, 'pace-run');
    const [tp] = (await reply(page, /^ok: t = ([0-9.]+) s, paused$/)) || [];
    check(tp, `pause holds the world's time (${tp} s)`);
    check(await clockAt(page, tp), `paused, the header's clock is the world's time (${tp} s)`);
    const label = await page.evaluate(() => document.getElementById('pace-run').textContent);
    check(label === 'go', `the pause button offers go (${label})`);

    const n0 = await page.evaluate(() => window.dcaMonitor.events.length);
    await click(page, 'pace-step');
    const [ts] = (await reply(page, /^ok: t = ([0-9.]+) s, paused$/)) || [];
    check(ts && Number(ts) > Number(tp) && Number(ts) - Number(tp) < 0.0105,
      `step: one tick of the world, then time holds (${tp} -> ${ts} s)`);
    check(await clockAt(page, ts), `the header's clock shows the step's time (${ts} s)`);

    await choose(page, '2');
    const two = await until(page, () => document.body.dataset.clockSpeed === '2', 20);
    check(two && (await reply(page, /^ok: (t = [0-9.]+ s, paused)$/)), 'the speed is set to 2x (time still held)');

    await click(page, 'pace-event');
    check(await reply(page, /^ok: (t = [0-9.]+ s, (running at 2x, stepping|paused))$/), 'to the next event: accepted');
    const te = await until(page, (t) => document.body.dataset.clock === 'paused' &&
      Number(document.body.dataset.clockT) > Number(t) && document.body.dataset.clockT, 60, ts);
    check(te, `to the next event: time holds after it (${ts} -> ${te} s)`);
    const n1 = await until(page, (n) => window.dcaMonitor.events.length > n && window.dcaMonitor.events.length, 20, n0);
    check(n1, `a transition at the event is shown (${n0} -> ${n1} events)`);
    await page.screenshot({ path: join(out, 'monitor_pace.png') });
    console.log(`screenshot: ${join(out, 'monitor_pace.png')}`);

    await choose(page, 'max');
    check(await until(page, () => document.body.dataset.clockSpeed === 'max', 20), 'max: unpaced');
    await click(page, 'pace-run');
    const ended = await until(page, () => document.querySelector('.row[data-path="main"]')?.dataset.state === 'done',
      120);
    check(ended, 'go, unpaced: the run ends DONE');
  } finally {
    run.p.kill('SIGTERM');
  }
}

await inBrowser(pace);
