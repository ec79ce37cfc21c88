// The monitor's 3D view of a URDF robot in a real browser (Debian's chromium, headless, software WebGL), live and
// in replay, compared pixel by pixel:
//   node robot.mjs DCA_EXE SOURCE_DIR OUT_DIR
// 1. Live: `dca run worlds/ur10/ur10_setpoint.dca --sim worlds/ur10/ur10.urdf --realtime --monitor --monitor-wait
//    --record FILE.mcap`: the page builds the UR10 from its URDF (primitives only: its visuals are cylinders) and
//    moves it with the link frames; once the run has ended, the 3D view shows its last sample, at tick T
//    (canvas data-t). Screenshot of the canvas.
// 2. Replay: `dca monitor FILE.mcap --system ur10_setpoint.dca`, the slider at T: the view shows the recorded
//    frames of tick T (data-t equal). Screenshot.
// 3. The two images differ in at most 0.5% of their pixels (by more than 16 of 255 in a channel), and the view
//    is no still life: the replay at tick 0 differs from T in more than 1% (the elbow and a wrist joint moved).
// Every wait is for something the page shows, with a deadline; the screenshots go to OUT_DIR.
import { mkdirSync, rmSync } from 'node:fs';
import { join } from 'node:path';
import { check, inChromium, startMonitor, until } from './driver.mjs';

const [exe, src, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });
const system = join(src, 'worlds/ur10/ur10_setpoint.dca');
const urdf = join(src, 'worlds/ur10/ur10.urdf');
const rec = join(out, 'ur10.mcap');
rmSync(rec, { force: true });

const start = (args) => startMonitor(exe, args);

// The canvas's pixels (RGBA), then a PNG of it (a live view may have moved on by then).
async function grab(page, name) {
  const pixels = await page.evaluate(() => {
    const c = document.getElementById('robot3d');
    const g = document.createElement('canvas');
    g.width = c.width; g.height = c.height;
    const x = g.getContext('2d');
    x.drawImage(c, 0, 0);
    return Array.from(x.getImageData(0, 0, g.width, g.height).data);
  });
  await (await page.$('#robot3d')).screenshot({ path: join(out, name) });
  console.log(`screenshot: ${join(out, name)}`);
  return pixels;
}

// The share of pixels differing by more than 16 in some channel.
function differing(a, b) {
  if (!a || !b || a.length !== b.length) return 1;
  let n = 0;
  for (let i = 0; i < a.length; i += 4) {
    if (Math.abs(a[i] - b[i]) > 16 || Math.abs(a[i + 1] - b[i + 1]) > 16 || Math.abs(a[i + 2] - b[i + 2]) > 16) n++;
  }
  return n / (a.length / 4);
}

async function open(browser, url) {
  const page = await browser.newPage();
  await page.setViewport({ width: 1400, height: 1200 });
  page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') console.log(`page: ${m.text()}`); });
  await page.goto(url);
  return page;
}

async function live(browser) {
  const run = await start(['run', system, '--sim', urdf, '--realtime', '--monitor', '--monitor-wait', '--record', rec]);
  try {
    const page = await open(browser, run.url);
    const first = await until(page, () => Number(document.getElementById('robot3d').dataset.frames) > 0 &&
      document.getElementById('robot3d').dataset.t, 30);
    check(first !== null, `the live page draws the UR10 from its URDF (first frames at t = ${first})`);
    const code = await Promise.race([run.exited, new Promise((r) => setTimeout(() => r('timeout'), 120000))]);
    check(code === 0, `the run ended DONE (exit ${code})`);
    await until(page, () => document.body.dataset.connected === 'no', 10);
    const t = await page.evaluate(() => document.getElementById('robot3d').dataset.t);
    const image = await grab(page, 'robot_live.png');
    const warn = await page.evaluate(() => document.getElementById('robot-warn').textContent);
    check(warn === '', `no warning in the 3D view (${warn})`);
    await page.close();
    return { t, image };
  } finally {
    run.p.kill('SIGTERM');
  }
}

async function replay(browser, t) {
  const mon = await start(['monitor', rec, '--system', system]);
  try {
    const page = await open(browser, mon.url);
    const ready = await until(page, () => document.body.dataset.mode === 'replay' &&
      Number(document.getElementById('robot3d').dataset.frames) > 0, 30);
    check(ready, 'the replay page draws the UR10 from the recorded URDF');
    const at = async (v) => {
      await page.evaluate((x) => {
        const s = document.getElementById('slider');
        s.value = String(x);
        s.dispatchEvent(new Event('input'));
      }, Number(v));
      return until(page, (x) => document.getElementById('robot3d').dataset.t === x && x, 10, v);
    };
    check(await at('0.000000') === '0.000000', 'the replay shows the recorded frames of tick 0');
    const start = await grab(page, 'robot_replay_start.png');
    const shown = await at(t);
    check(shown === t, `the replay shows the recorded frames of tick ${t} (${shown})`);
    const image = await grab(page, 'robot_replay.png');
    await page.close();
    return { image, start };
  } finally {
    mon.p.kill('SIGTERM');
  }
}

const code = await inChromium(async (browser) => {
  const l = await live(browser);
  const r = await replay(browser, l.t);
  const d = differing(l.image, r.image);
  check(d < 0.005, `live and replay at t = ${l.t} s differ in ${(100 * d).toFixed(3)}% of the pixels (under 0.5%)`);
  const moved = differing(r.start, r.image);
  check(moved > 0.01, `the robot moved between t = 0 and ${l.t} (${(100 * moved).toFixed(2)}% of the pixels differ)`);
}, ['--use-angle=swiftshader', '--enable-unsafe-swiftshader']);
rmSync(rec, { force: true });
process.exit(code);
