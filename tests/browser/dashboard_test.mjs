// camlab's dashboard in a real browser (Debian's chromium, headless, driven by
// playwright-core over the DevTools protocol). Starts the built camlabd with its virtual
// camera on a loopback port and a temporary data folder, then checks what a camera
// engineer would do and see:
//   - without the token every data endpoint of the API answers 401 (each route of the
//     OpenAPI document, the live stream and the event stream included) and the page shows
//     its login; a wrong token is refused;
//   - after logging in, live frames arrive and change;
//   - setting the exposure moves the histogram as the sensor's physics says: the mean
//     above the black level grows with the exposure time (the virtual camera is linear);
//   - a bracket started from the page finishes, its thumbnails show, the exposure analysis
//     started from the page draws its linearity plot;
//   - focus peaking and clipping overlays draw; the page logs no console error.
// Screenshots go to $CAMLAB_SCREENSHOT_DIR (default ./screenshots). Every wait is bounded.
//
//   node dashboard_test.mjs CAMLABD_PATH
import { spawn } from 'node:child_process';
import { createHash } from 'node:crypto';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { chromium } from 'playwright-core';

const camlabd = process.argv[2];
const chromiumPath = process.env.CAMLAB_CHROMIUM || '/usr/bin/chromium';
const screenshots = process.env.CAMLAB_SCREENSHOT_DIR || path.resolve('screenshots');
const failures = [];
let daemon = null;
let browser = null;
let dataDir = null;

function check(condition, what) {
  console.log(`${condition ? 'ok  ' : 'FAIL'} ${what}`);
  if (!condition) failures.push(what);
  return condition;
}

async function waitFor(what, predicate, timeoutMs) {
  const deadline = Date.now() + timeoutMs;
  for (;;) {
    const value = await predicate();
    if (value) return value;
    if (Date.now() > deadline) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 200));
  }
}

async function startDaemon() {
  dataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'camlab_dashboard_'));
  const log = path.join(dataDir, 'camlabd.log');
  const out = fs.openSync(log, 'w');
  daemon = spawn(camlabd, ['--listen', '127.0.0.1:0', '--data', path.join(dataDir, 'data')],
    { stdio: ['ignore', out, out] });
  const port = await waitFor('camlabd to listen', () => {
    const m = fs.readFileSync(log, 'utf8').match(/listening on http:\/\/127\.0\.0\.1:(\d+)/);
    return m ? Number(m[1]) : 0;
  }, 60000);
  const token = fs.readFileSync(path.join(dataDir, 'data', 'token'), 'utf8').trim();
  return { base: `http://127.0.0.1:${port}`, token, log };
}

// Without the token: every route but the public ones (health, the dashboard's files)
// answers 401, whatever its method, with the path parameters filled with real values.
async function checkEveryRouteNeedsTheToken(base, token, cameraId) {
  const doc = await (await fetch(`${base}/v1/openapi.json`,
    { headers: { Authorization: `Bearer ${token}` } })).json();
  const publicPaths = new Set(['/v1/health', '/', '/ui/{name}']);
  let checked = 0;
  for (const [route, methods] of Object.entries(doc.paths)) {
    const url = route.replace('{id}', route.startsWith('/v1/cameras') ? encodeURIComponent(cameraId) : '1')
      .replace('{n}', '0').replace('{name}', 'linearity.png').replace('{session}', '1');
    for (const method of Object.keys(methods)) {
      const response = await fetch(`${base}${url}`, {
        method: method.toUpperCase(),
        body: ['post', 'put'].includes(method) ? '{}' : undefined,
        headers: { 'Content-Type': 'application/json' },
      });
      await response.arrayBuffer().catch(() => null);
      if (publicPaths.has(route)) continue;
      checked += 1;
      if (response.status !== 401) check(false, `${method.toUpperCase()} ${url} without the token: ${response.status}`);
    }
  }
  check(checked >= 20, `every one of the ${checked} data endpoints answers 401 without the token`);
  const page = await fetch(`${base}/`);
  check(page.status === 200 && (await page.text()).includes('API token'),
    'the dashboard page itself is served without the token (it holds no data)');
}

async function main() {
  if (!camlabd || !fs.existsSync(camlabd)) throw new Error(`usage: node dashboard_test.mjs CAMLABD_PATH (got ${camlabd})`);
  if (!fs.existsSync(chromiumPath))
    throw new Error(`${chromiumPath} is missing: scripts/install-deps.sh installs Debian's chromium`);
  fs.mkdirSync(screenshots, { recursive: true });
  const { base, token } = await startDaemon();
  const auth = { Authorization: `Bearer ${token}` };
  const { cameras } = await (await fetch(`${base}/v1/cameras`, { headers: auth })).json();
  const cameraId = cameras[0].id;
  await checkEveryRouteNeedsTheToken(base, token, cameraId);

  browser = await chromium.launch({
    executablePath: chromiumPath,
    headless: true,
    // Root in CI has no user namespaces for the sandbox; the machines have no network, so
    // everything that would reach out is off.
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const context = await browser.newContext({ viewport: { width: 1400, height: 1000 } });
  const page = await context.newPage();
  const consoleErrors = [];
  let expectRefusal = false;
  page.on('console', (msg) => {
    if (msg.type() !== 'error') return;
    // The one deliberate wrong token is answered 401, which Chromium logs.
    if (expectRefusal && msg.text().includes('401')) return;
    consoleErrors.push(msg.text());
  });
  page.on('pageerror', (error) => consoleErrors.push(`page error: ${error.message}`));

  await page.goto(`${base}/`);
  await page.waitForSelector('#login:not([hidden])', { timeout: 10000 });
  check(await page.isHidden('#app'), 'without the token the page shows only its login');
  await page.screenshot({ path: path.join(screenshots, 'login.png') });

  expectRefusal = true;
  await page.fill('#token', 'not-the-token');
  await page.click('#login-button');
  await page.waitForFunction(() => document.querySelector('#login-error').textContent.includes('refused'),
    null, { timeout: 10000 });
  check(true, 'a wrong token is refused with a message');

  await page.fill('#token', token);
  await page.click('#login-button');
  await page.waitForSelector('#app:not([hidden])', { timeout: 10000 });
  expectRefusal = false;
  check(!(await page.evaluate(() => location.href.includes(sessionStorage.getItem('camlab.token')))),
    'the token is not in the page address');

  // Live frames arrive and change: new sequence numbers, new pixels (the sensor's noise).
  await page.waitForFunction(() => Number(document.querySelector('#live-canvas').dataset.frames) >= 3,
    null, { timeout: 30000 });
  const snap = async () => page.evaluate(() => {
    const c = document.querySelector('#live-canvas');
    return { sequence: Number(c.dataset.sequence), frames: Number(c.dataset.frames), pixels: c.toDataURL('image/png') };
  });
  const a = await snap();
  await page.waitForTimeout(1500);
  const b = await snap();
  const hash = (s) => createHash('sha1').update(s).digest('hex');
  check(b.sequence > a.sequence && b.frames > a.frames, `live frames keep coming (sequence ${a.sequence} -> ${b.sequence})`);
  check(hash(a.pixels) !== hash(b.pixels), 'the live picture changes from frame to frame');
  const rateText = await page.textContent('#live-status');
  const rate = Number((rateText.match(/([\d.]+) frames\/s/) || [])[1]);
  // An upper bound only (the cap is a promise; the rate reached is the benchmark's to say).
  check(rate > 0 && rate <= 11, `the live view keeps under its cap of 10 frames/s (${rate} over 3 s)`);

  // The histogram moves with the exposure, as the physics says: the signal above black
  // doubles when the exposure time doubles (below saturation).
  await page.waitForFunction(() => document.querySelector('#histogram-canvas').dataset.mean, null, { timeout: 20000 });
  const black = await (async () => {
    const h = await (await fetch(`${base}/v1/cameras/${encodeURIComponent(cameraId)}/histogram`, { headers: auth })).json();
    return h.black_level_dn;
  })();
  const exposureInput = '#controls input[type=number][data-control="exposure_time_absolute"]';
  const before = Number(await page.inputValue(exposureInput));
  const mean = async () => Number(await page.evaluate(() => document.querySelector('#histogram-canvas').dataset.mean));
  const mean1 = await mean();
  const target = before * 2;
  await page.fill(exposureInput, String(target));
  await page.press(exposureInput, 'Enter');
  await page.locator(exposureInput).evaluate((el) => el.dispatchEvent(new Event('change')));
  await page.waitForFunction((t) => (document.querySelector('[data-applied-for="exposure_time_absolute"]') || {})
    .textContent?.includes(`applied ${t}`), target, { timeout: 10000 });
  check(true, `exposure set from the page and read back (${before} -> ${target} x 100 us)`);
  let ratio = 0;
  await waitFor('the histogram to follow the exposure', async () => {
    ratio = (await mean() - black) / (mean1 - black);
    return Math.abs(ratio - 2) < 0.06;
  }, 20000).catch(() => {});
  check(Math.abs(ratio - 2) < 0.06, `the histogram's mean above black follows the exposure: x${ratio.toFixed(3)} for x2`);
  await page.screenshot({ path: path.join(screenshots, 'exposure-histogram.png') });

  // Overlays: focus peaking and clipping.
  await page.check('#live-peaking');
  await page.check('#live-clipping');
  const framesBefore = Number(await page.evaluate(() => document.querySelector('#live-canvas').dataset.frames));
  await page.waitForFunction((n) => Number(document.querySelector('#live-canvas').dataset.frames) > n + 3,
    framesBefore, { timeout: 20000 });
  const green = await page.evaluate(() => {
    const c = document.querySelector('#live-canvas');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 0; i < d.length; i += 4) if (d[i + 1] > 200 && d[i] < 80 && d[i + 2] < 80) n++;
    return n;
  });
  check(green > 100, `focus peaking marks the sharp edges (${green} px)`);
  await page.locator('#live-panel').screenshot({ path: path.join(screenshots, 'live-overlays.png') });

  // A bracket from the page, then its exposure analysis and the linearity plot.
  await page.selectOption('#capture-kind', 'bracket');
  await page.fill('#bracket-exposures', '1000, 2000, 4000, 8000');
  await page.fill('#capture-repeats', '2');
  await page.click('#capture-start');
  const jobId = await waitFor('the bracket job', () => page.evaluate(() => document.querySelector('#job-panel').dataset.jobId), 10000);
  await page.waitForSelector(`#jobs tr[data-job-id="${jobId}"][data-state="succeeded"]`, { timeout: 120000 });
  check(true, `the bracket (job ${jobId}) started from the page succeeded, its progress shown live`);
  await page.waitForFunction(() => document.querySelectorAll('#job-frames img.thumbnail').length === 8 &&
    [...document.querySelectorAll('#job-frames img.thumbnail')].every((i) => i.complete && i.naturalWidth > 0),
  null, { timeout: 30000 });
  check(true, 'its 8 frames show as thumbnails with their settings');
  await page.click('#job-actions button[data-analysis="exposure"]');
  await page.waitForFunction(() => {
    const img = document.querySelector('#job-plots img.plot[data-name="linearity.png"]');
    return img && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 120000 });
  check(true, 'the exposure analysis started from the page shows its linearity plot');
  const summary = await page.textContent('#job-summary');
  const linearity = Number((summary.match(/linearity: max error ([\d.]+) %/) || [])[1]);
  check(linearity < 1, `the bracket is linear within 1 % (max error ${linearity} %)`);
  await page.screenshot({ path: path.join(screenshots, 'dashboard.png'), fullPage: true });

  // Every file the bracket wrote is listed on its page and downloads byte for byte.
  await page.click(`#jobs tr[data-job-id="${jobId}"]`);
  await page.waitForSelector('#job-files:not([hidden]) a[data-path="frame_000000.png"]',
    { state: 'attached', timeout: 20000 });
  await page.click('#job-files summary');
  const listedFiles = await page.evaluate(() =>
    [...document.querySelectorAll('#job-files a[data-path]')].map((a) => a.dataset.path));
  check(listedFiles.includes('manifest.json') && listedFiles.filter((p) => p.endsWith('.png')).length === 8,
    `the bracket's page lists its files (${listedFiles.length}: manifest, 8 frames, their sidecars)`);
  const [download] = await Promise.all([
    page.waitForEvent('download', { timeout: 20000 }),
    page.click('#job-files a[data-path="frame_000000.png"]'),
  ]);
  const downloaded = fs.readFileSync(await download.path());
  const served = Buffer.from(await (await fetch(`${base}/v1/jobs/${jobId}/frames/0`, { headers: auth })).arrayBuffer());
  check(downloaded.equals(served) && download.suggestedFilename() === 'frame_000000.png',
    `a file downloaded from the page is the frame byte for byte (${downloaded.length} bytes)`);

  // A long capture cancelled from its page: it ends cancelled, with the frames kept so far.
  const openBefore = await page.evaluate(() => document.querySelector('#job-panel').dataset.jobId);
  await page.fill('#bracket-exposures', '1000, 2000, 4000, 8000');
  await page.fill('#capture-repeats', '100');
  await page.click('#capture-start');
  const longId = await waitFor('the long bracket job', async () => {
    const id = await page.evaluate(() => document.querySelector('#job-panel').dataset.jobId);
    return id && id !== openBefore ? id : null;
  }, 10000);
  await page.waitForSelector(`#jobs tr[data-job-id="${longId}"][data-state="running"]`, { timeout: 60000 });
  await page.click('#job-cancel');
  await page.waitForSelector(`#jobs tr[data-job-id="${longId}"][data-state="cancelled"]`, { timeout: 30000 });
  const cancelled = await (await fetch(`${base}/v1/jobs/${longId}`, { headers: auth })).json();
  check(cancelled.state === 'cancelled' && cancelled.result.frames_kept < 400,
    `the capture cancelled from its page ended cancelled after ${cancelled.result.frames_kept} of 400 frames`);
  check(await page.isHidden('#job-cancel'), 'an ended job offers no cancel');

  // Logging out, and a new tab (a fresh session) without the token, show the login.
  const fresh = await browser.newContext();
  const other = await fresh.newPage();
  await other.goto(`${base}/`);
  await other.waitForSelector('#login:not([hidden])', { timeout: 10000 });
  check(await other.isHidden('#app'), 'a new browser session starts at the login');
  await page.click('#logout');
  await page.waitForSelector('#login:not([hidden])', { timeout: 10000 });
  check(!(await page.evaluate(() => sessionStorage.getItem('camlab.token'))), 'logging out forgets the token');

  check(consoleErrors.length === 0, `no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
}

let exitCode = 0;
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
  exitCode = failures.length ? 1 : 0;
  console.log(failures.length ? `${failures.length} check(s) failed` : 'all checks passed');
}
process.exit(exitCode);
