// What the browser tests share: dca started with its monitor's address awaited, and waits on the page.
//   const run = await startMonitor(EXE, ARGS)   run.p, run.url, run.exited (--> exit code), run.output()
//   await runToEnd(EXE, ARGS)                    --> the exit code of EXE ARGS, run to its end
//   await record(EXE, RUN_ARGS, FILE)            --> the exit code of `EXE run RUN_ARGS` recorded into FILE
//   await seek(page, t)                          the replay's slider at t, drawn
//   await until(page, fn, seconds, ...args)      fn's value in the page once truthy (polled), or null after seconds
//   check(ok, what)                              prints ok / FAIL and counts the failures
//   await inChromium(body, args)                 body(browser) in headless chromium --> exit code: 1 on a failure
//   await inBrowser(body)                        the same, then exits with that code
import { spawn } from 'node:child_process';
import { rmSync } from 'node:fs';
import puppeteer from 'puppeteer-core';

// dca's children stop when the process that started them is gone (DCA_PARENT_PID, host/spawn.h): this script's
// own children must not inherit the variable meant for this script.
export const childEnv = { ...process.env };
delete childEnv.DCA_PARENT_PID;

// Starts `EXE ARGS` and resolves once it printed its monitor's URL (within 60 s).
export function startMonitor(exe, args) {
  const p = spawn(exe, args, { stdio: ['ignore', 'pipe', 'pipe'], env: childEnv });
  let text = '';
  const exited = new Promise((resolve) => p.on('exit', (code) => resolve(code)));
  return new Promise((resolve, reject) => {
    const deadline = setTimeout(() => reject(new Error(`no monitor address within 60 s:\n${text}`)), 60000);
    const look = (chunk) => {
      text += chunk;
      const m = text.match(/monitor: (http:\/\/\S+)/);
      if (m) { clearTimeout(deadline); resolve({ p, url: m[1], exited, output: () => text }); }
    };
    p.stdout.on('data', look);
    p.stderr.on('data', look);
    p.on('exit', (code) => { clearTimeout(deadline); reject(new Error(`dca exited (${code}) before its monitor:\n${text}`)); });
  });
}

// Runs `EXE ARGS` (e.g. a run that records) to its end, its output ignored. --> its exit code
export function runToEnd(exe, args) {
  return new Promise((resolve) => {
    const p = spawn(exe, args, { stdio: 'ignore', env: childEnv });
    p.on('exit', resolve);
  });
}

// `EXE run ARGS` recorded into `rec` (made anew) with every port, to its end. --> its exit code
export function record(exe, args, rec) {
  rmSync(rec, { force: true });
  return runToEnd(exe, ['run', ...args, '--record', rec, '--record-ports', 'all', '--quiet']);
}

// Sets the replay's slider to `t` as a user's drag does, and waits for two frames (the page has drawn it).
export async function seek(page, t) {
  await page.evaluate((v) => {
    const s = document.getElementById('slider');
    s.value = String(v);
    s.dispatchEvent(new Event('input'));
  }, t);
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
}

export async function until(page, fn, seconds, ...args) {
  try {
    const h = await page.waitForFunction(fn, { timeout: seconds * 1000, polling: 50 }, ...args);
    return await h.jsonValue();
  } catch (e) {
    return null;
  }
}

let failures = 0;
export function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures++;
}

// Runs body(browser) in Debian's chromium (or $DCA_CHROMIUM), headless, with chromium's `args` beside the
// defaults; a throw is a failure. Then prints the verdict. --> the exit code: 1 if any check failed
export async function inChromium(body, args = ['--disable-gpu']) {
  const browser = await puppeteer.launch({
    executablePath: process.env.DCA_CHROMIUM || '/usr/bin/chromium', headless: true,
    args: ['--no-sandbox', ...args, '--disable-dev-shm-usage', '--no-first-run'],
  });
  try {
    await body(browser);
  } catch (e) {
    console.log(`FAIL ${e.stack || e}`);
    failures++;
  } finally {
    await browser.close();
  }
  console.log(failures ? `${failures} check(s) failed` : 'all checks passed');
  return failures ? 1 : 0;
}

// inChromium(body), then the process exits with its code.
export async function inBrowser(body) {
  process.exit(await inChromium(body));
}
