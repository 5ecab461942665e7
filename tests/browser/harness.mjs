// What the browser tests share: checks that print and count, bounded waits, camlabd started
// on a loopback port with a temporary data folder (and stopped, its log shown on failure),
// Debian's chromium launched headless, and a stored frame's raw DN read from its PNG here,
// independently of camlabd.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';
import { chromium } from 'playwright-core';

export const chromiumPath = process.env.CAMLAB_CHROMIUM || '/usr/bin/chromium';
export const screenshots = process.env.CAMLAB_SCREENSHOT_DIR || path.resolve('screenshots');
const failures = [];
let daemon = null;
let browser = null;
let dataDir = null;

export function check(condition, what) {
  console.log(`${condition ? 'ok  ' : 'FAIL'} ${what}`);
  if (!condition) failures.push(what);
  return condition;
}

export async function waitFor(what, predicate, timeoutMs) {
  const deadline = Date.now() + timeoutMs;
  for (;;) {
    const value = await predicate();
    if (value) return value;
    if (Date.now() > deadline) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 200));
  }
}

// camlabd with `args` beside the listen address and data folder: {base, token, auth, log}.
export async function startDaemon(camlabd, args = []) {
  if (!camlabd || !fs.existsSync(camlabd)) throw new Error(`usage: node TEST.mjs CAMLABD_PATH (got ${camlabd})`);
  dataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'camlab_browser_'));
  const log = path.join(dataDir, 'camlabd.log');
  const out = fs.openSync(log, 'w');
  daemon = spawn(camlabd, ['--listen', '127.0.0.1:0', '--data', path.join(dataDir, 'data'), ...args],
    { stdio: ['ignore', out, out] });
  const port = await waitFor('camlabd to listen', () => {
    const m = fs.readFileSync(log, 'utf8').match(/listening on http:\/\/127\.0\.0\.1:(\d+)/);
    return m ? Number(m[1]) : 0;
  }, 60000);
  const token = fs.readFileSync(path.join(dataDir, 'data', 'token'), 'utf8').trim();
  return { base: `http://127.0.0.1:${port}`, token, auth: { Authorization: `Bearer ${token}` }, log,
    data: path.join(dataDir, 'data') };
}

export async function launchBrowser() {
  if (!fs.existsSync(chromiumPath))
    throw new Error(`${chromiumPath} is missing: scripts/install-deps.sh installs Debian's chromium`);
  fs.mkdirSync(screenshots, { recursive: true });
  browser = await chromium.launch({
    executablePath: chromiumPath,
    headless: true,
    // Root in CI has no user namespaces for the sandbox; the machines have no network, so
    // everything that would reach out is off.
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  return browser;
}

// A page of the dashboard, logged in with `token`, that collects the console's errors.
export async function loggedInPage(base, token) {
  const context = await (await launchBrowser()).newContext({ viewport: { width: 1400, height: 1100 } });
  const page = await context.newPage();
  const consoleErrors = [];
  page.on('console', (msg) => { if (msg.type() === 'error') consoleErrors.push(msg.text()); });
  page.on('pageerror', (error) => consoleErrors.push(`page error: ${error.message}`));
  await page.goto(`${base}/`);
  await page.fill('#token', token);
  await page.click('#login-button');
  await page.waitForSelector('#app:not([hidden])', { timeout: 10000 });
  return { page, consoleErrors };
}

// Runs `main`, then stops the browser and camlabd (which must exit cleanly on SIGTERM),
// prints the tally and exits with its status.
export async function run(main) {
  try {
    await main();
  } catch (error) {
    console.log(`FAIL ${error.stack || error}`);
    failures.push(String(error));
  } finally {
    if (browser) await browser.close().catch(() => {});
    if (daemon) {
      daemon.kill('SIGTERM');
      const code = await new Promise((resolve) => {
        const timer = setTimeout(() => { daemon.kill('SIGKILL'); resolve(-1); }, 30000);
        daemon.on('exit', (c) => { clearTimeout(timer); resolve(c); });
      });
      check(code === 0, `camlabd stopped cleanly on SIGTERM (exit ${code})`);
    }
    if (failures.length && dataDir) {
      const log = path.join(dataDir, 'camlabd.log');
      if (fs.existsSync(log)) console.log(`--- camlabd's log ---\n${fs.readFileSync(log, 'utf8').slice(-4000)}`);
    }
    if (dataDir) fs.rmSync(dataDir, { recursive: true, force: true });
    console.log(failures.length ? `${failures.length} check(s) failed` : 'all checks passed');
  }
  process.exit(failures.length ? 1 : 0);
}

// A stored frame's raw DN read from its PNG: greyscale or RGB, 8 or 16 bits, not
// interlaced (what camlabd writes). Returns {width, height, channels, at(x, y, plane)}.
export function decodePng(bytes) {
  let offset = 8;
  let header = null;
  const idat = [];
  while (offset < bytes.length) {
    const length = bytes.readUInt32BE(offset);
    const type = bytes.toString('ascii', offset + 4, offset + 8);
    const data = bytes.subarray(offset + 8, offset + 8 + length);
    if (type === 'IHDR') header = { width: data.readUInt32BE(0), height: data.readUInt32BE(4),
      depth: data[8], colour: data[9], interlace: data[12] };
    if (type === 'IDAT') idat.push(data);
    offset += 12 + length;
  }
  if (!header || header.interlace || ![0, 2].includes(header.colour) || ![8, 16].includes(header.depth))
    throw new Error(`decodePng: unsupported PNG ${JSON.stringify(header)}`);
  const channels = header.colour === 2 ? 3 : 1;
  const bpp = channels * header.depth / 8;
  const stride = header.width * bpp;
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const out = Buffer.alloc(stride * header.height);
  for (let y = 0; y < header.height; y++) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let i = 0; i < stride; i++) {
      const a = i >= bpp ? out[y * stride + i - bpp] : 0;
      const b = y > 0 ? out[(y - 1) * stride + i] : 0;
      const c = i >= bpp && y > 0 ? out[(y - 1) * stride + i - bpp] : 0;
      const p = a + b - c;
      const pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
      const predictor = [0, a, b, (a + b) >> 1, pa <= pb && pa <= pc ? a : pb <= pc ? b : c][filter];
      out[y * stride + i] = (line[i] + predictor) & 0xff;
    }
  }
  const at = (x, y, plane) => {
    const i = y * stride + (x * channels + plane) * (header.depth / 8);
    return header.depth === 16 ? out.readUInt16BE(i) : out[i];
  };
  return { width: header.width, height: header.height, channels, at };
}

// The channel of pixel (x, y) as camlabd names it: Y (mono), R/Gr/Gb/B by filter site.
export function channelOf(pattern, x, y) {
  if (!pattern) return 'Y';
  const site = (y % 2) * 2 + (x % 2);
  const colour = pattern[site];
  if (colour !== 'G') return colour;
  return pattern[site ^ 1] === 'R' ? 'Gr' : 'Gb';
}
