// The monitor's plot panel (page/plot.js, docs/monitor.md "The plot") in headless chromium:
//   node plot.mjs live DCA_EXE SOURCE_DIR OUT_DIR     a small system on the mock UR10, watched live to its end
//   node plot.mjs replay DCA_EXE SOURCE_DIR OUT_DIR   the same run recorded, then replayed (dca monitor FILE.mcap)
// Live: time paused at once (the pace control), two ports chosen from the topic tree, then the run goes on to its
// end (3 s at 1x); a world signal and a port chosen late come from the run's start (the server's history: every
// port tapped from the start, --monitor-taps all), and a port never chosen is there from the start after the end.
// After the end:
// both series drawn with their names and units, a hover readout of a value and the timeline's cursor at the
// same time, the wheel's zoom and a drag's pan change the x range, the filter, and a reason for a chosen signal
// with no samples. Replay: the whole run drawn whatever the slider, the playhead at the slider's time, the
// slider labelled with times and marked at the transitions. Every wait is for something the page shows.
import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { check, inBrowser, record, seek, startMonitor, until } from './driver.mjs';

const [mode, exe, src, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });
// A Constant 1 into a Gain of 2, a Counter, each ticking every 10 ms; a Timer ends the run DONE after 20 s (paced
// at 1x until the test sets the speed to max: time enough to choose signals while it runs, however slow the page).
const system = join(out, 'plot_live.dca');
writeFileSync(system, `process main() {
  instantiated_processes { one instof Constant("h1", 0.01, 1); scale instof Gain("h1", 2, 0.01);
                           ramp instof Counter("h1", 0.01); two instof Constant("h1", 0.01, 3);
                           idle instof Counter("h1", 0.01);
                           stop instof Timer("h1", 20); }
  internal_connections(scale, feed) { one, Out -> scale, In; }
  internal_event_actions { stop # (one, ramp, two, scale[feed]) }
}
`);
const world = `mock:${join(src, 'worlds/ur10/ur10.urdf')}`;

// Clicks the topic `name` in the plot's tree once the page offers it.
async function choose(page, name) {
  const ok = await until(page, (n) => {
    const row = [...document.querySelectorAll('#plot-topics .ptopic')].find((r) => r.dataset.name === n);
    if (row) row.click();
    return !!row;
  }, 20, name);
  check(ok, `the topic tree offers ${name}, and it is chosen`);
}

// Clicks the element `sel` from inside the page, in one step (the tree and the legend are redrawn as samples come).
const clickIn = (page, sel) => page.evaluate((s) => document.querySelector(s).click(), sel);

const plotData = (page) => page.evaluate(() => {
  const c = document.getElementById('plot');
  return { x0: Number(c.dataset.x0), x1: Number(c.dataset.x1), series: Number(c.dataset.series),
    cursor: c.dataset.cursor, playhead: c.dataset.playhead, legend: document.getElementById('legend').textContent,
    reason: document.getElementById('plot-reason').hidden ? '' : document.getElementById('plot-reason').textContent,
    readout: document.getElementById('plot-readout').hidden ? '' : document.getElementById('plot-readout').textContent,
    timelineCursor: document.getElementById('timeline').dataset.cursor };
});
const frames = (page) => page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
// The rows the page keeps of topic `name`: [count, first t, last t].
const rowsOf = (page, name) => page.evaluate((n) => {
  const t = [...window.dcaPlotPanel.P.topics.values()].find((x) => x.name === n);
  return t ? [t.rows.length, t.rows.length ? t.rows[0][0] : null, t.rows.length ? t.rows[t.rows.length - 1][0] : null]
    : [0, null, null];
}, name);

async function live(browser) {
  const run = await startMonitor(exe, ['run', system, '--sim', world, '--monitor', '--monitor-wait']);
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 1000 });
    await page.goto(run.url);
    check(await until(page, () => !document.getElementById('pace').hidden, 30), 'the pace control is shown');
    await page.click('#pace-run');
    check(await until(page, () => /^ok: t = [0-9.]+ s, paused$/.test(document.getElementById('reply').textContent), 20),
      'time is paused while the signals are chosen');
    await choose(page, '/main/one/Out');
    await choose(page, '/main/scale/Out');
    const t0 = await page.evaluate(() => Number(document.body.dataset.clockT));
    await page.click('#pace-run');  // go, at 1x
    check(await until(page, (t) => Number(document.body.dataset.clockT) > t + 0.5, 20, t0), `time runs on past ${t0 + 0.5} s`);
    const late = await until(page, () => [...document.querySelectorAll('#plot-topics .ptopic')]
      .find((r) => r.dataset.name.startsWith('/world/safety/'))?.dataset.name, 5);
    if (late) {
      await choose(page, late);
      const got = await until(page, (n) => {
        const t = [...window.dcaPlotPanel.P.topics.values()].find((x) => x.name === n);
        return t && t.rows.length > 3 && [t.rows[0][0]];
      }, 20, late);
      check(got && got[0] < 0.3, `${late}, chosen after 0.5 s, starts at the run's start (${got} s: the server's history)`);
      await clickIn(page, `#plot-topics .ptopic[data-name="${late}"]`);  // chosen no more
    } else check(false, 'a world signal /world/safety/... is offered');
    // a port chosen late: from the run's start too (tapped from the start; the server's hub kept it)
    await choose(page, '/main/two/Out');
    const two = await until(page, () => {
      const t = [...window.dcaPlotPanel.P.topics.values()].find((x) => x.name === '/main/two/Out');
      return t && t.rows.length > 3 && [t.rows[0][0], t.rows[0][1], t.rows.length];
    }, 20);
    check(two && two[0] < 0.3 && two[1] === 3,
      `/main/two/Out, chosen after ${t0 + 0.5} s, starts at the run's start with its value 3 (${two}: t, value, rows)`);
    await clickIn(page, '#plot-topics .ptopic[data-name="/main/two/Out"]');  // chosen no more
    const n = await until(page, () => Number(document.getElementById('plot').dataset.samples) >= 40 &&
      Number(document.getElementById('plot').dataset.samples), 20);
    check(n, `the two ports' samples come (${n})`);
    await page.select('#pace-speed', 'max');  // to the end, unpaced
    check(await until(page, () => document.body.dataset.connected === 'no', 60), 'the run ends (the page disconnected)');
    await frames(page);
    const [n1, a1, b1] = await rowsOf(page, '/main/one/Out');
    const [n2, a2, b2] = await rowsOf(page, '/main/scale/Out');
    check(n1 >= 20 && n2 >= 20 && b1 > 19 && b2 > 19 && a1 < t0 + 0.5 && a2 < t0 + 0.5,
      `after the end, both topics keep their rows (${n1}: ${a1}..${b1} s, ${n2}: ${a2}..${b2} s)`);
    let d = await plotData(page);
    check(d.series === 2 && d.legend.includes('one.Out') && d.legend.includes('scale.Out'),
      `two series from two topics on one plot, named by their ports (${d.legend})`);
    check(!d.reason, `no reason shown while they have samples (${d.reason})`);
    await page.screenshot({ path: join(out, 'plot_live_end.png'), fullPage: true });

    // hover: the readout at the pointer's time, and the timeline's cursor at the same time
    const box = await page.$eval('#plot', (c) => { const r = c.getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; });
    await page.mouse.move(box[0] + box[2] * 0.6, box[1] + box[3] / 2);
    await frames(page);
    await until(page, () => document.getElementById('timeline').dataset.cursor, 5);
    d = await plotData(page);
    check(/one\.Out\[0\] = 1(?![0-9.])/.test(d.readout) && /scale\.Out\[0\] = 2(?![0-9.])/.test(d.readout),
      `the hover readout gives one.Out's value 1 and scale.Out's 2 at t = ${d.cursor} s (${d.readout})`);
    check(d.cursor && d.cursor === d.timelineCursor, `the timeline's cursor is at the plot's (${d.cursor} = ${d.timelineCursor})`);
    await page.screenshot({ path: join(out, 'plot_hover.png'), fullPage: true });

    // the wheel zooms in around the pointer; a drag pans
    const before = [d.x0, d.x1];
    await page.mouse.wheel({ deltaY: -300 });
    await frames(page);
    d = await plotData(page);
    check(d.x1 - d.x0 < (before[1] - before[0]) * 0.9, `the wheel zooms in: x ${before.join('..')} -> ${d.x0}..${d.x1} s`);
    const zoomed = [d.x0, d.x1];
    await page.mouse.down();
    await page.mouse.move(box[0] + box[2] * 0.3, box[1] + box[3] / 2, { steps: 4 });
    await page.mouse.up();
    await frames(page);
    d = await plotData(page);
    check(d.x0 > zoomed[0] && Math.abs((d.x1 - d.x0) - (zoomed[1] - zoomed[0])) < 1e-3,
      `a drag pans: x ${zoomed.join('..')} -> ${d.x0}..${d.x1} s`);
    await page.screenshot({ path: join(out, 'plot_zoomed.png'), fullPage: true });
    // a click on the legend hides a series (its values out of the readout), another shows it again
    await clickIn(page, '#legend .pseries[data-key$=":1"]:last-child');
    await page.mouse.move(box[0] + box[2] * 0.6, box[1] + box[3] / 2);
    await frames(page);
    d = await plotData(page);
    check(d.series === 1 && !/scale\.Out/.test(d.readout), `a click on scale.Out[0] in the legend hides it (${d.series} series: ${d.readout})`);
    await clickIn(page, '#legend .pseries[data-key$=":1"]:last-child');
    await frames(page);
    check((await plotData(page)).series === 2, 'another click shows it again');
    await page.click('#plot-reset');
    await frames(page);
    d = await plotData(page);
    check(Math.abs(d.x0 - before[0]) < 1e-3 && Math.abs(d.x1 - before[1]) < 1e-3, `reset zoom: ${d.x0}..${d.x1} s`);

    // the filter: only the topics whose name has it
    await page.type('#plot-filter', 'scale');  // (then cleared: every topic again)
    await frames(page);
    const listed = await page.evaluate(() => [...document.querySelectorAll('#plot-topics .ptopic')].map((r) => r.dataset.name));
    check(listed.length === 1 && listed[0] === '/main/scale/Out', `the filter leaves /main/scale/Out alone (${listed})`);
    await page.evaluate(() => { const f = document.getElementById('plot-filter'); f.value = ''; f.dispatchEvent(new Event('input')); });

    // a world status topic never chosen while the run went: the page followed it from the start all the same
    const stale = late && late.replace(/[^/]*$/, late.endsWith('clamps') ? 'stale' : 'clamps');
    const [ns, as] = stale ? await rowsOf(page, stale) : [0, null];
    check(ns > 20 && as < 0.3, `${stale}, never chosen, is there after the end from the start (${ns} rows from ${as} s)`);

    // a port never chosen while the run went (a world signal): sent at the end, there from the start to the end
    const [nv, av, bv] = await rowsOf(page, '/world/joint/shoulder_pan_joint/velocity');
    check(nv > 20 && av < 0.3 && bv > 19,
      `/world/joint/shoulder_pan_joint/velocity, never chosen, is there after the end: ${nv} rows, ${av}..${bv} s`);
    // a port's unit from its manifest, beside its name
    await page.click('#plot-clear');
    await choose(page, '/world/joint/shoulder_pan_joint/velocity');
    await frames(page);
    d = await plotData(page);
    check(d.legend === 'shoulder_pan_joint.velocity[0] rad/s', `the unit from the manifest beside the name (${d.legend})`);

    // a topic with no samples: a reason, not an empty box
    await page.click('#plot-clear');
    await page.evaluate(() => { const f = document.getElementById('plot-filter'); f.value = 'idle'; f.dispatchEvent(new Event('input')); });
    await choose(page, '/main/idle/Count');  // (a leaf the run never runs: its port never sends)
    await frames(page);
    d = await plotData(page);
    check(/\/main\/idle\/Count: no samples, and the run has ended/.test(d.reason), `a reason instead of an empty plot (${d.reason})`);
    await page.screenshot({ path: join(out, 'plot_reason.png'), fullPage: true });
  } finally {
    run.p.kill('SIGTERM');
  }
}

async function replay(browser) {
  const rec = join(out, 'test_live.mcap');
  const code = await record(exe, [system, '--sim', world], rec);
  check(code === 0, `the run recorded ${rec} (exit ${code})`);
  const mon = await startMonitor(exe, ['monitor', rec, '--system', system]);
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 1000 });
    await page.goto(mon.url);
    check(await until(page, () => document.body.dataset.mode === 'replay', 20), 'the recording is shown in replay mode');
    await choose(page, '/main/one/Out');
    await choose(page, '/main/scale/Out');
    check(await until(page, () => Number(document.getElementById('plot').dataset.samples) > 100, 10), 'both signals come whole');
    const end = await page.evaluate(() => window.dcaMonitor.t);
    const at = async (t) => {
      await seek(page, t);
      return { ...(await plotData(page)), samples: await page.$eval('#plot', (c) => Number(c.dataset.samples)),
        rows: await page.$eval('#timeline', (c) => Number(c.dataset.rows)) };
    };
    const a = await at(0.2), b = await at(end * 0.8);
    check(a.x0 === 0 && Math.abs(a.x1 - end) < 1e-3 && a.samples === b.samples && a.x1 === b.x1,
      `the whole run is drawn whatever the slider (0..${a.x1} s, ${a.samples} rows at 0.2 s and at ${(end * 0.8).toFixed(2)} s)`);
    check(a.playhead === '0.200' && b.playhead === (end * 0.8).toFixed(3),
      `the playhead moves with the slider (${a.playhead} -> ${b.playhead} s)`);
    check(a.rows === b.rows && a.rows >= 3, `the timeline shows the whole run at any slider time (${a.rows} / ${b.rows} rows)`);
    const scale = await page.evaluate(() => ({
      labels: [...document.querySelectorAll('#slider-labels span')].map((s) => s.textContent),
      marks: [...document.querySelectorAll('#slider-marks i')].map((i) => i.style.left) }));
    check(scale.labels.length === 6 && scale.labels[0] === '0.0 s' && scale.labels[5] === `${end.toFixed(1)} s`,
      `the slider is labelled with times (${scale.labels.join(', ')})`);
    check(scale.marks.join() === '0%,100%', `the slider marks the run's transitions: the start, the end (${scale.marks})`);
    // a click on the plot moves the slider there
    const box = await page.$eval('#plot', (c) => { const r = c.getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; });
    const [x0, x1] = await page.$eval('#plot', (c) => [Number(c.dataset.x0), Number(c.dataset.x1)]);
    await page.mouse.click(box[0] + 56 + (box[2] - 66) * 0.25, box[1] + box[3] / 2);  // (the frame's margins: 56, 10)
    await frames(page);
    const c = await plotData(page);
    const slider = await page.$eval('#slider', (e) => Number(e.value));
    check(Math.abs(Number(c.playhead) - (x0 + (x1 - x0) * 0.25)) < 0.1 && Math.abs(slider - Number(c.playhead)) < 1e-3,
      `a click a quarter into the plot moves the slider and the playhead there (${c.playhead} s, slider ${slider})`);
    await page.screenshot({ path: join(out, 'plot_replay.png'), fullPage: true });
    console.log(`screenshots: ${out}`);
  } finally {
    mon.p.kill('SIGTERM');
  }
}

await inBrowser(async (browser) => {
  if (mode === 'replay') await replay(browser);
  else await live(browser);
});
