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
import { createHash } from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';
import {
  channelOf, check, decodePng, launchBrowser, run, screenshots, startDaemon, waitFor,
} from './harness.mjs';

const camlabd = process.argv[2];

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
  const { base, token, auth } = await startDaemon(camlabd);
  const { cameras } = await (await fetch(`${base}/v1/cameras`, { headers: auth })).json();
  const cameraId = cameras[0].id;
  await checkEveryRouteNeedsTheToken(base, token, cameraId);

  const browser = await launchBrowser();
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

  // Overexposed: the clipped bin is marked with its share, as camlabd counts it.
  const setExposure = async (value) => {
    await page.fill(exposureInput, String(value));
    await page.locator(exposureInput).evaluate((el) => el.dispatchEvent(new Event('change')));
    await page.waitForFunction((t) => (document.querySelector('[data-applied-for="exposure_time_absolute"]') || {})
      .textContent?.includes(`applied ${t}`), value, { timeout: 10000 });
  };
  const maxExposure = Number(await page.getAttribute(exposureInput, 'max'));
  await setExposure(Math.min(maxExposure, target * 40));
  const clippedShown = await waitFor('the clipped bin to be marked', () => page.evaluate(() =>
    Number(document.querySelector('#histogram-canvas').dataset.clippedMarked) > 0 &&
    document.querySelector('#histogram-stats').textContent), 20000).catch(() => '');
  const servedHistogram = await (await fetch(`${base}/v1/cameras/${encodeURIComponent(cameraId)}/histogram`, { headers: auth })).json();
  const share = (servedHistogram.channels[0].clipped_high_fraction * 100).toFixed(1);
  check(Boolean(clippedShown) && servedHistogram.channels[0].clipped_high > 0,
    `overexposed, the histogram marks its clipped bin (camlabd: ${share} % clipped)`);
  await page.locator('#histogram-panel').screenshot({ path: path.join(screenshots, 'histogram-clipped.png') });
  await setExposure(target);

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
  // The rest needs no preview frames: paused, camlabd renders none beside the captures.
  await page.click('#live-pause');

  // The camera's formats, sizes and frame rates to choose from: every one it lists; the
  // bracket is taken in a chosen one (a linear one other than camlabd's own choice, if any).
  const camera = await (await fetch(`${base}/v1/cameras/${encodeURIComponent(cameraId)}`, { headers: auth })).json();
  const listed = camera.formats.reduce((n, f) => n + f.sizes.reduce((m, z) => m + Math.max(1, z.intervals.length), 0), 0);
  await page.waitForFunction((n) => document.querySelectorAll('#capture-format option').length === n + 1,
    listed, { timeout: 10000 }).catch(() => {});
  const formatOptions = await page.evaluate(() =>
    [...document.querySelectorAll('#capture-format option')].map((o) => o.value).filter((v) => v).map((v) => JSON.parse(v)));
  check(formatOptions.length === listed && listed > 0,
    `the capture form offers each of the camera's ${listed} formats x sizes x frame rates`);
  const linear = formatOptions.filter((f) => !['MJPG', 'JPEG', 'YUYV'].includes(f.fourcc.trim()));
  const chosenFormat = linear[linear.length - 1] || formatOptions[0];
  await page.selectOption('#capture-format', JSON.stringify(chosenFormat));

  // The aperture series and the lens map hold the exposure across the stops when given a
  // time at the first (base_exposure_us); the aperture series leaves it out when empty.
  const formRequest = (kind, fill) => page.evaluate(async ([k, f]) => {
    const form = document.querySelector('#capture-form');
    form.querySelector('#capture-kind').value = k;
    for (const [id, value] of Object.entries(f)) form.querySelector(id).value = value;
    return (await import('/ui/captures.js')).captureRequest(form);
  }, [kind, fill]);
  const heldSeries = await formRequest('aperture_series', { '#aperture-base-exposure': '1500' });
  const plainSeries = await formRequest('aperture_series', { '#aperture-base-exposure': '' });
  const heldMap = await formRequest('lens_map', { '#lens-map-base-exposure': '2500' });
  check(heldSeries.base_exposure_us === 1500 && !('base_exposure_us' in plainSeries) &&
    !('exposure_us' in heldSeries) && heldSeries.f_numbers.length === 5 && heldMap.base_exposure_us === 2500,
  'the aperture-series and lens-map forms send base_exposure_us when given (1500, 2500 us) and the series none when empty');

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
  const bracketJob = await (await fetch(`${base}/v1/jobs/${jobId}`, { headers: auth })).json();
  const frameMeta = await (await fetch(`${base}/v1/jobs/${jobId}/frames/0/meta`, { headers: auth })).json();
  check(bracketJob.request.format.fourcc.trim() === chosenFormat.fourcc.trim() &&
    bracketJob.request.format.width === chosenFormat.width &&
    frameMeta.delivered_format.trim() === chosenFormat.fourcc.trim(),
  `the bracket ran in the format chosen on the page (${chosenFormat.fourcc.trim()} ${chosenFormat.width} x ${chosenFormat.height}; frames delivered as ${frameMeta.delivered_format})`);
  await page.click('#job-actions button[data-analysis="exposure"]');
  await page.waitForSelector('#job-plots figure[data-name="linearity.png"][data-drawn="chart"] .uplot canvas',
    { timeout: 120000 });
  // The interactive chart holds the plot's own data: every point the analysis wrote.
  const analysisId = await page.evaluate(() => document.querySelector('#job-panel').dataset.jobId);
  const plotList = (await (await fetch(`${base}/v1/jobs/${analysisId}/plots`, { headers: auth })).json()).plots;
  const linearityData = await (await fetch(`${base}${plotList.find((p) => p.name === 'linearity.png').data}`,
    { headers: auth })).json();
  const finite = linearityData.series.reduce((n, s) => n + s.y.filter((v, i) => v !== null && s.x[i] !== null).length, 0);
  const chartPoints = Number(await page.evaluate(() =>
    document.querySelector('#job-plots figure[data-name="linearity.png"] .chart').dataset.points));
  check(chartPoints === finite && finite > 0,
    `the exposure analysis started from the page charts its linearity (uPlot, ${chartPoints} points of the plot's data)`);
  await page.click('#job-plots figure[data-name="linearity.png"] button');
  await page.waitForFunction(() => {
    const img = document.querySelector('#job-plots figure[data-name="linearity.png"] img.plot');
    return img && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 20000 });
  check(true, "and its PNG (gnuplot's drawing) one click away");
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

  // The viewer: a frame opened from its thumbnail at 1:1; the DN under the cursor and an
  // ROI's statistics are the stored frame's own, read here from the PNG.
  const png = decodePng(served);
  await page.click('#job-frames img.thumbnail[data-index="0"]');
  await page.waitForFunction(() => Number(document.querySelector('#viewer-canvas').dataset.frameWidth) > 0,
    null, { timeout: 20000 });
  const frameSize = await page.evaluate(() => {
    const c = document.querySelector('#viewer-canvas');
    return [Number(c.dataset.frameWidth), Number(c.dataset.frameHeight)];
  });
  check(frameSize[0] === png.width && frameSize[1] === png.height,
    `the viewer opens the frame at its size (${frameSize.join(' x ')} px)`);
  await page.click('#viewer-one');
  check(Number(await page.evaluate(() => document.querySelector('#viewer-canvas').dataset.zoom)) === 1,
    'the viewer zooms to 1:1');
  await page.click('#viewer-zoom-in');
  await page.click('#viewer-zoom-in');
  check(Number(await page.evaluate(() => document.querySelector('#viewer-canvas').dataset.zoom)) === 4,
    'and in to 4:1');
  await page.locator('#viewer-panel').screenshot({ path: path.join(screenshots, 'viewer-zoomed.png') });
  const box = await page.locator('#viewer-canvas').boundingBox();
  await page.mouse.move(box.x + box.width * 0.37, box.y + box.height * 0.61);
  await page.waitForFunction(() => document.querySelector('#viewer-pixel').dataset.x !== undefined, null, { timeout: 10000 });
  const cursor = await page.evaluate(() => {
    const d = document.querySelector('#viewer-pixel').dataset;
    return { x: Number(d.x), y: Number(d.y), dn: Number(d.dn), samples: JSON.parse(d.samples) };
  });
  const regionInfo = await (await fetch(`${base}/v1/jobs/${jobId}/frames/0/region`, { headers: auth })).json();
  const pattern = regionInfo.cfa_pattern;
  // A colour PNG holds R, G, B in that order; a mono or mosaic one a sample a pixel.
  const plane = (channel) => (png.channels === 3 ? { R: 0, G: 1, B: 2 }[channel] : 0);
  const everySampleMatches = cursor.samples.length > 0 && cursor.samples.every((s) =>
    s.dn === png.at(s.x, s.y, plane(s.channel)) &&
    (png.channels === 3 || s.channel === channelOf(pattern, s.x, s.y)));
  check(everySampleMatches && cursor.samples.some((s) => s.x === cursor.x && s.y === cursor.y),
    `the DN under the cursor is the stored frame's: (${cursor.x}, ${cursor.y}) ${cursor.samples.map((v) => `${v.channel} ${v.dn}`).join(', ')} DN`);
  await page.click('#viewer-fit');
  await page.check('#viewer-roi-mode');
  await page.mouse.move(box.x + box.width * 0.30, box.y + box.height * 0.30);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width * 0.45, box.y + box.height * 0.42, { steps: 4 });
  await page.mouse.up();
  await page.waitForFunction(() => document.querySelector('#viewer-roi').dataset.channels, null, { timeout: 10000 });
  const roi = await page.evaluate(() => {
    const d = document.querySelector('#viewer-roi').dataset;
    return { rect: JSON.parse(d.rect), channels: JSON.parse(d.channels) };
  });
  const truth = new Map();
  for (let y = roi.rect.y; y < roi.rect.y + roi.rect.height; y++) {
    for (let x = roi.rect.x; x < roi.rect.x + roi.rect.width; x++) {
      const names = png.channels === 3 ? ['R', 'G', 'B'] : [channelOf(pattern, x, y)];
      for (const name of names) {
        const t = truth.get(name) || { n: 0, sum: 0 };
        t.n += 1;
        t.sum += png.at(x, y, plane(name));
        truth.set(name, t);
      }
    }
  }
  const roiMatches = roi.channels.length === truth.size && roi.channels.every((c) => {
    const t = truth.get(c.channel);
    return t && t.n === c.samples && Math.abs(c.mean_dn - t.sum / t.n) < 1e-6 * Math.max(1, c.mean_dn);
  });
  check(roi.rect.width > 10 && roi.rect.height > 10 && roiMatches,
    `the ROI's mean per channel is the stored frame's (${roi.rect.width} x ${roi.rect.height} px: ` +
    `${roi.channels.map((c) => `${c.channel} ${c.mean_dn.toFixed(2)} DN, SNR ${Number(c.snr).toFixed(1)}`).join('; ')})`);
  await page.locator('#viewer-panel').screenshot({ path: path.join(screenshots, 'viewer-roi.png') });
  await page.click('#viewer-close');

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
  // The cancel button stays the same element while progress rewrites the summary on every
  // frame: rebuilt each time, a click whose press and release fell either side of a rebuild
  // was lost (this capture once ran on to its end in CI).
  await page.waitForSelector('#job-cancel');
  await page.evaluate((id) => {
    window.cancelButtonSeen = document.querySelector('#job-cancel');
    window.jobRowSeen = document.querySelector(`#jobs tr[data-job-id="${id}"]`);
  }, longId);
  const framesThen = await page.evaluate(() => document.querySelector('#job-summary').textContent);
  await page.waitForFunction((before) => document.querySelector('#job-summary').textContent !== before,
    framesThen, { timeout: 10000 });
  check(await page.evaluate(() => document.querySelector('#job-cancel') === window.cancelButtonSeen),
    'the running capture\'s cancel button outlives its progress updates');
  check(await page.evaluate((id) => {
    const row = document.querySelector(`#jobs tr[data-job-id="${id}"]`);
    return row === window.jobRowSeen && /frames/.test(row.textContent);
  }, longId), 'and so does its row in the jobs table, its progress rewritten in place');
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

await run(main);
