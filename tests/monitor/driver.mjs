// What the browser tests share: dca started with its monitor's address awaited, and waits on the page.
//   const run = await startMonitor(EXE, ARGS)   run.p, run.url, run.exited (--> exit code), run.output()
//   await until(page, fn, seconds, ...args)      fn's value in the page once truthy (polled), or null after seconds
import { spawn } from 'node:child_process';

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

export async function until(page, fn, seconds, ...args) {
  try {
    const h = await page.waitForFunction(fn, { timeout: seconds * 1000, polling: 50 }, ...args);
    return await h.jsonValue();
  } catch (e) {
    return null;
  }
}
