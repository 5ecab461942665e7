// Result pages in a real browser: every analysis kind opens on a summary that is the job's
// own data. camlabd runs the virtual camera whose focus surface is tilted and curved, on the
// lens-map chart (slanted squares over the field). A focus stack, an aperture series and a
// lens map are captured through the API; each analysis is started from the capture's page,
// and its page must show
//   - the analysis's summary (what was measured, what was left out and why) as the report
//     gives it, and
//   - its headline numbers as the report holds them: the depth map's valid share, each V-curve's
//     best focus, C = k/N's k, the median MTF50, the lens map's tilt and curvature per stop,
//   - its plots, loaded.
// Screenshots of each page go to $CAMLAB_SCREENSHOT_DIR. Every wait is bounded.
//
//   node results_test.mjs CAMLABD_PATH SOURCE_DIR
import path from 'node:path';
import { check, loggedInPage, run, screenshots, startDaemon, waitFor } from './harness.mjs';

const [camlabd, sourceDir] = process.argv.slice(2);

const median = (values) => {
  const sorted = [...values].sort((a, b) => a - b);
  const mid = sorted.length >> 1;
  return sorted.length % 2 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
};

// What each analysis's page must show beyond its summary: [description, text] pairs made
// from the report with the unit and precision the page states.
function headlines(kind, report) {
  if (kind === 'focus')
    return [['the depth map\'s valid share', `${(100 * report.summary.depth_valid_share).toFixed(1)} % of the pixels have a depth`]];
  if (kind === 'defocus') {
    const out = [];
    const v = report.targets.find((t) => t.coc_vs_focus && t.coc_vs_focus.best_position !== undefined);
    if (v) out.push([`${v.name}'s V-curve`, `${v.name}: V-curve best focus ${v.coc_vs_focus.best_position.toFixed(2)} ± ` +
      `${v.coc_vs_focus.best_position_sigma.toFixed(2)} steps`]);
    const a = report.targets.find((t) => t.coc_vs_aperture && t.coc_vs_aperture.k_px !== undefined);
    if (a) out.push([`${a.name}'s C = k/N`, `${a.name}: CoC = k/N with k ${a.coc_vs_aperture.k_px.toFixed(2)} ± ` +
      `${a.coc_vs_aperture.k_sigma_px.toFixed(2)} px`]);
    return out;
  }
  if (kind === 'sfr') {
    const edges = report.frames.flatMap((f) => f.edges);
    const mtf50 = edges.map((e) => e.mtf50_cy_px).filter(Number.isFinite);
    const relative = edges.filter((e) => Number.isFinite(e.mtf50_cy_px) && e.mtf50_cy_px > 0 &&
      Number.isFinite(e.mtf50_standard_error_cy_px))
      .map((e) => 100 * e.mtf50_standard_error_cy_px / e.mtf50_cy_px);
    return [['the median MTF50', `MTF50 over ${mtf50.length} edge fits: median ${median(mtf50).toFixed(3)} cycles/px`],
      ['the median MTF50 standard error', `MTF50 standard error: median ${median(relative).toFixed(2)} % of the MTF50 ` +
        `(${relative.length} fits)`]];
  }
  if (kind === 'lensmap')
    return report.surfaces.map((s) => [`f/${s.f_number}'s surface`,
      `f/${s.f_number}: tilt ${s.at_sensor.tilt_x_deg.toFixed(3)} ± ${s.at_sensor.standard_errors.tilt_x_deg.toFixed(3)} deg right, ` +
      `${s.at_sensor.tilt_y_deg.toFixed(3)} ± ${s.at_sensor.standard_errors.tilt_y_deg.toFixed(3)} deg down; ` +
      `field curvature ${s.at_sensor.curvature_um.toFixed(1)} ± ${s.at_sensor.standard_errors.curvature_um.toFixed(1)} um`]);
  return [];
}

async function main() {
  const examples = path.join(sourceDir || '', 'mock_device', 'examples');
  const { base, token, auth } = await startDaemon(camlabd, ['--no-scan',
    '--camera-spec', path.join(examples, 'camera_640x480_field_focus.json'),
    '--scene', path.join(examples, 'scene_lensmap_chart.json')]);
  const call = async (route, body) => (await fetch(`${base}${route}`, {
    method: body ? 'POST' : 'GET', headers: { ...auth, 'Content-Type': 'application/json' },
    body: body ? JSON.stringify(body) : undefined,
  })).json();
  const { cameras } = await call('/v1/cameras');
  const capturesUrl = `/v1/cameras/${encodeURIComponent(cameras[0].id)}/captures`;

  // The captures, one after another on the one camera (1000 us: no stop clips).
  const captures = {};
  for (const [name, request] of Object.entries({
    focus_stack: { kind: 'focus_stack', start: 15, stop: 113, step: 14, repeats: 1, exposure_us: 1000 },
    aperture_series: { kind: 'aperture_series', f_numbers: [1.4, 2.8, 5.6, 8], repeats: 1, exposure_us: 1000 },
    lens_map: { kind: 'lens_map', f_numbers: [1.4, 2.8], start: 15, stop: 113, step: 14, repeats: 1, base_exposure_us: 2000 },
  })) {
    const job = await call(capturesUrl, request);
    const done = await call(`/v1/jobs/${job.id}?wait=60`);
    check(done.state === 'succeeded', `the ${name} capture (job ${job.id}) succeeded with ${done.result?.frames_kept} frames`);
    captures[name] = job.id;
  }

  const { page, consoleErrors } = await loggedInPage(base, token);
  // The live view is not under test here: paused, camlabd renders and encodes no preview
  // frames beside the analyses (on 2 cores, beside the rest of the suite).
  await page.click('#live-pause');

  for (const [capture, kind] of [['focus_stack', 'focus'], ['focus_stack', 'defocus'],
    ['aperture_series', 'defocus'], ['aperture_series', 'sfr'], ['lens_map', 'lensmap']]) {
    const captureId = captures[capture];
    await page.click(`#jobs tr[data-job-id="${captureId}"]`);
    await page.waitForSelector(`#job-actions button[data-analysis="${kind}"]`, { timeout: 20000 });
    await page.click(`#job-actions button[data-analysis="${kind}"]`);
    const jobId = await waitFor(`the ${kind} analysis of the ${capture}`, async () => {
      const id = Number(await page.evaluate(() => document.querySelector('#job-panel').dataset.jobId));
      return id && id !== captureId ? id : null;
    }, 10000);
    await page.waitForSelector(`#job-panel[data-job-id="${jobId}"][data-state="succeeded"]`, { timeout: 120000 });
    const job = await call(`/v1/jobs/${jobId}`);
    const report = job.result.report;
    await page.waitForFunction((text) => document.querySelector('#job-summary').textContent.includes(text),
      report.summary.text.split('\n')[0], { timeout: 10000 }).catch(() => {});
    const shown = await page.textContent('#job-summary');
    const what = `${kind} of the ${capture} (job ${jobId})`;
    check(report.summary.text.split('\n').every((line) => shown.includes(line)),
      `the ${what} opens on its summary: "${report.summary.text.split('\n')[0]}"`);
    const expected = headlines(kind, report);
    check(expected.length > 0, `the ${what} has headline numbers to show (${expected.length})`);
    for (const [name, text] of expected)
      check(shown.includes(text), `the ${what} shows ${name}: "${text}"`);
    check(!/NaN|undefined/.test(shown), `the ${what}'s summary shows no NaN or undefined`);
    const plots = (await call(`/v1/jobs/${jobId}/plots`)).plots.filter((p) => !p.name.endsWith('_raw.png'));
    if (plots.length) {
      // Each an interactive chart or, for heat maps and the like, gnuplot's PNG.
      const shownPlots = () => page.evaluate(() => [...document.querySelectorAll('#job-plots figure')]
        .filter((f) => (f.dataset.drawn === 'chart' && f.querySelector('.uplot canvas')) ||
          (f.dataset.drawn === 'image' && f.querySelector('img.plot').complete &&
           f.querySelector('img.plot').naturalWidth > 0)).length);
      await waitFor(`the ${what}'s plots`, async () => (await shownPlots()) === plots.length, 30000).catch(() => {});
      const charts = await page.evaluate(() => document.querySelectorAll('#job-plots figure[data-drawn="chart"]').length);
      check(await shownPlots() === plots.length,
        `the ${what} shows its ${plots.length} plot(s), ${charts} as interactive charts`);
    }
    await page.locator('#job-panel').screenshot({ path: path.join(screenshots, `result-${kind}-${capture}.png`) });
  }
  check(consoleErrors.length === 0, `no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
}

await run(main);
