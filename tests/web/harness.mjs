// What the browser tests share (tests/web/): finding chromium and
// playwright-core (exit 77 without them), a chromod on loopback with its web
// view, waiting on the page, and the page's width check.
import { createRequire } from 'node:module';
import { spawn } from 'node:child_process';
import { existsSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const SKIP = 77;
export const repository = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');

// {playwright, chromium}; exits 77 (skipped) without Debian's chromium or web/node_modules.
export function browserOrSkip() {
  const chromium = process.env.CHROMO_CHROMIUM ?? '/usr/bin/chromium';
  if (!existsSync(chromium)) {
    console.log(`SKIPPED: no chromium at ${chromium} (scripts/setup.sh installs it)`);
    process.exit(SKIP);
  }
  try {
    return { playwright: createRequire(path.join(repository, 'web/package.json'))('playwright-core'), chromium };
  } catch (error) {
    console.log(`SKIPPED: playwright-core not installed in web/node_modules (build the target web): ${error.message}`);
    process.exit(SKIP);
  }
}

// A chromod with its web view on 127.0.0.1. start() resolves with the
// view's origin once it listens; stop() sends SIGTERM and waits (SIGKILL and
// a failure after 15 s).
export class Chromod {
  constructor(binary, home, configFile, runDir) {
    Object.assign(this, { binary, home, configFile, runDir, process: null });
  }

  get socket() { return path.join(this.runDir, 'chromod.sock'); }

  start(port = 0) {
    this.process = spawn(this.binary, ['--config', this.configFile, '--socket', this.socket,
      '--sessions-dir', path.join(this.home, 'sessions'), '--web', `127.0.0.1:${port}`],
    { env: { ...process.env, CHROMO_HOME: this.home, CHROMO_RUNTIME_DIR: this.runDir }, stdio: ['ignore', 'pipe', 'pipe'] });
    this.process.stderr.on('data', (data) => process.stderr.write(`[chromod] ${data}`));
    return new Promise((resolve, reject) => {
      let output = '';
      this.process.stdout.on('data', (data) => {
        output += data;
        const listening = output.match(/web view on (http:\/\/[0-9.]+:[0-9]+)\//);
        if (listening) resolve(listening[1]);
      });
      this.process.on('exit', (code) => reject(new Error(`chromod exited (${code}) before listening: ${output}`)));
    });
  }

  stop() {
    const daemon = this.process;
    return new Promise((resolve) => {
      if (!daemon || daemon.exitCode !== null) return resolve();
      daemon.removeAllListeners('exit');
      const stubborn = setTimeout(() => {
        console.error('FAIL: chromod did not stop within 15 s of SIGTERM; killed');
        process.exitCode = 1;
        daemon.kill('SIGKILL');
      }, 15000);
      daemon.on('exit', () => { clearTimeout(stubborn); resolve(); });
      daemon.kill('SIGTERM');
    });
  }
}

// page.waitForFunction evaluates a string in the page, which the page's CSP
// (no unsafe-eval) refuses: poll page.evaluate from here instead.
export async function waitUntil(page, predicate, argument, timeoutMs, what) {
  const deadline = performance.now() + timeoutMs;
  while (!(await page.evaluate(predicate, argument))) {
    if (performance.now() > deadline) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
    await new Promise((resolve) => setTimeout(resolve, 100));
  }
}

// The page's width and its scrolling width (equal when nothing scrolls sideways).
export function pageWidth(page) {
  return page.evaluate(() => ({ scroll: document.documentElement.scrollWidth, client: document.documentElement.clientWidth }));
}

// The words of the page's labels, headers, cells and buttons that wrap across
// two lines (a word broken inside itself: "spectrom|eter", "Dele|te"); a word
// is a run of letters and digits, so "white_|d65" wrapping after "_" is not one.
export function wordsBrokenAcrossLines(page) {
  return page.evaluate(() => {
    const broken = [];
    const scope = 'th, td, button, label, legend, caption, h2, h3, h4, dt, dd, summary, figcaption';
    for (const element of document.querySelectorAll(`main :is(${scope})`)) {
      if (!element.getClientRects().length) continue;
      const walker = document.createTreeWalker(element, NodeFilter.SHOW_TEXT);
      for (let node = walker.nextNode(); node; node = walker.nextNode()) {
        if (node.parentElement.closest(scope) !== element) continue;  // counted with its own element
        for (const match of node.data.matchAll(/[\p{L}\p{N}]+/gu)) {
          const range = document.createRange();
          range.setStart(node, match.index);
          range.setEnd(node, match.index + match[0].length);
          const lines = new Set([...range.getClientRects()].filter((r) => r.width > 0).map((r) => Math.round(r.top / 4)));
          if (lines.size > 1) broken.push(`"${match[0]}" in ${element.tagName.toLowerCase()} "${element.textContent.slice(0, 60)}"`);
        }
      }
    }
    return broken;
  });
}

// Logs in from node (POST /login) and returns the session cookie.
export async function logIn(origin, token) {
  const reply = await fetch(`${origin}/login`, { method: 'POST', headers: { 'Content-Type': 'application/json', Origin: origin },
    body: JSON.stringify({ token }) });
  if (reply.status !== 200) throw new Error(`POST /login: ${reply.status}`);
  return reply.headers.get('set-cookie').split(';')[0];
}

// The web API from node: {status, json} of POST /api/<service>/<method>.
export async function callApi(origin, cookie, service, method, body, headers = {}) {
  const reply = await fetch(`${origin}/api/${service}/${method}`, { method: 'POST',
    headers: { 'Content-Type': 'application/json', Origin: origin, Cookie: cookie, ...headers }, body: JSON.stringify(body) });
  return { status: reply.status, json: await reply.json() };
}

// Runs a test's main: "PASS", or "FAIL: <stack>" and exit status 1; cleanup always.
export async function runMain(main, cleanup) {
  try {
    await main();
    console.log('PASS');
  } catch (error) {
    console.error(`FAIL: ${error.stack ?? error}`);
    process.exitCode = 1;
  } finally {
    await cleanup();
  }
}
