// A fleet from the monitor's page in a real browser (Debian's chromium, headless):
//   node fleet.mjs DCA_EXE SOURCE_DIR OUT_DIR
// `dca run scripts/systems/fleet.dca --monitor` (real daemons on loopback, wall clock): the root's row has a
// `+robots` button; a click (the host asked for: r2) adds a robot, whose rows come with the next tree, its light
// running on r2; its row's `remove` button removes it, and the run says so. Then the run is interrupted.
// Every wait is for something the page or the run says, with a deadline.
import { mkdirSync } from 'node:fs';
import { join } from 'node:path';
import { check, inChromium, startMonitor, until } from './driver.mjs';

const [exe, src, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });

process.exit(await inChromium(async (browser) => {
  const run = await startMonitor(exe, ['run', join(src, 'scripts/systems/fleet.dca'), '--monitor']);
  try {
    const page = await browser.newPage();
    await page.goto(run.url);
    check(await until(page, () => document.body.dataset.mode === 'live', 30), 'the page is live');
    const add = '.row[data-path="main"] button[data-cmd="add_child"]';
    check(await until(page, (s) => document.querySelector(s) !== null, 30, add), 'the root has a +robots button');
    check(await page.$eval(add, (b) => b.textContent) === '+robots', 'named after the template');
    // the host is asked for: the user answers r2
    await page.evaluate(() => { window.prompt = () => 'r2'; });
    await page.$eval(add, (b) => b.click());
    const light = '.row[data-path="main.robots_r2.light"][data-state="running"][data-host="r2"]';
    check(await until(page, (s) => document.querySelector(s) !== null, 30, light),
      'the robot joined: its light runs on r2');
    check(run.output().includes('main.robots_r2: added on host r2'), 'the run says it was added');
    await page.$eval('.row[data-path="main.robots_r2"] button[data-cmd="remove_child"]', (b) => b.click());
    check(await until(page, () => document.getElementById('lines').textContent.includes('main.robots_r2: removed'),
      30), 'the robot left: the run says so');
    check(await until(page, () => {
      const r = document.querySelector('.row[data-path="main.robots_r2"]');
      return r && r.dataset.state === 'removed';
    }, 30), 'its row says removed');
    await page.screenshot({ path: join(out, 'fleet.png') });
    await page.close();
    run.p.kill('SIGINT');
    const code = await Promise.race([run.exited, new Promise((r) => setTimeout(() => r('timeout'), 60000))]);
    check(code !== 'timeout', `the run stopped on SIGINT (exit ${code})`);
  } finally {
    run.p.kill('SIGTERM');
  }
}));
