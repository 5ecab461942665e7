// The guided calibration panel in a real browser. camlabd runs the 1280x800 virtual camera
// looking at a chessboard (14 x 10 inner corners, 40 mm) that stays where it is. From the
// page: a session is started, a view taken; the panel must show the suggestion camlabd
// made (the same words as GET /v1/calibration-sessions/{id}) and draw the suggested board
// over the live view; the same view taken again is refused as a repeat of view 0, and the
// page says so with camlabd's code. Then a calibration of a rendered set of 40 views (the
// same board in 40 poses, `camlab render`) opens on its summary: the model, the RMS, the
// field of view and focal length with their 1-sigma errors as the report gives them, and
// its plots. Every wait is bounded.
//
//   node guided_test.mjs CAMLABD_PATH SOURCE_DIR CAMLAB_CLI_PATH
import { execFileSync } from 'node:child_process';
import path from 'node:path';
import { check, loggedInPage, run, screenshots, startDaemon, waitFor } from './harness.mjs';

const [camlabd, sourceDir, cli] = process.argv.slice(2);

async function main() {
  const examples = path.join(sourceDir || '', 'mock_device', 'examples');
  const { base, token, auth, data } = await startDaemon(camlabd, ['--no-scan',
    '--camera-spec', path.join(examples, 'camera_wide_1280x800.json'),
    '--scene', path.join(examples, 'scene_chessboard_calibration.json')]);
  const session = async (id) => (await fetch(`${base}/v1/calibration-sessions/${id}`, { headers: auth })).json();

  const { page, consoleErrors } = await loggedInPage(base, token);
  await page.waitForFunction(() => Number(document.querySelector('#live-canvas').dataset.frames) >= 2,
    null, { timeout: 30000 });

  await page.click('#guided-start');
  await page.waitForSelector('#guided-session:not([hidden])', { timeout: 10000 });
  await page.click('#guided-take');
  await page.waitForFunction(() => {
    const d = document.querySelector('#guided-session').dataset;
    return d.views === '1' && d.phase === 'ready';
  }, null, { timeout: 60000 });
  const id = Number((await page.textContent('#guided-status')).match(/session (\d+)/)[1]);
  const first = await session(id);
  const shown = await page.evaluate(() => document.querySelector('#guided-suggestion').dataset.description);
  check(first.suggestion && shown === first.suggestion.description,
    `after the first view the panel shows camlabd's suggestion: "${shown}"`);

  // The suggested board over the live view: its dashed outline in the overlay's yellow,
  // on the live picture's scale, along the suggestion's top edge.
  const framesNow = Number(await page.evaluate(() => document.querySelector('#live-canvas').dataset.frames));
  await page.waitForFunction((n) => Number(document.querySelector('#live-canvas').dataset.frames) > n + 1 &&
    document.querySelector('#live-canvas').dataset.overlay === '1', framesNow, { timeout: 20000 });
  const onOutline = await page.evaluate((s) => {
    const c = document.querySelector('#live-canvas');
    const scale = c.width / s.imager_px[0];
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    const yellow = (x, y) => {
      for (let dy = -2; dy <= 2; dy++) for (let dx = -2; dx <= 2; dx++) {
        const i = 4 * (Math.round(y + dy) * c.width + Math.round(x + dx));
        if (d[i] > 200 && d[i + 1] > 170 && d[i + 2] < 90) return true;
      }
      return false;
    };
    // Samples along the top edge (first to second outer corner); dashes leave gaps.
    let hits = 0;
    const o = s.outline_px;
    for (let t = 0.05; t < 1; t += 0.05)
      if (yellow((o[0] + t * (o[2] - o[0])) * scale, (o[1] + t * (o[3] - o[1])) * scale)) hits++;
    return hits;
  }, first.suggestion);
  check(onOutline >= 8, `the suggested board is drawn over the live view along its top edge (${onOutline} of 19 samples)`);
  await page.locator('#live-panel').screenshot({ path: path.join(screenshots, 'guided-live.png') });
  await page.click('#live-pause');  // the rest needs no preview frames

  // The board has not moved: the next view repeats view 0 and is refused with the reason.
  await page.click('#guided-take');
  await page.waitForFunction(() => {
    const d = document.querySelector('#guided-session').dataset;
    return d.refused === '1' && d.phase === 'ready';
  }, null, { timeout: 60000 });
  const second = await session(id);
  const refusal = await page.textContent('#guided-refusal');
  check(second.last_error && second.last_error.code === 'duplicate_view' &&
    refusal.startsWith('duplicate_view') && refusal.includes('view 0'),
    `a repeat of view 0 is refused, and the page says why: "${refusal.slice(0, 90)}..."`);
  check(second.views_with_board === 1 && (await page.textContent('#guided-status')).includes('1 view(s) taken, 1 refused'),
    'the refused view is not counted as taken');
  await page.locator('#guided-panel').screenshot({ path: path.join(screenshots, 'guided-panel.png') });

  await page.click('#guided-cancel');
  await page.waitForSelector('#guided-session', { state: 'hidden', timeout: 10000 });
  check((await session(id)).state === 'cancelled', 'Cancel session ends the session');
  // A calibration's page: what the report says, with units and 1-sigma errors.
  execFileSync(cli, ['render', '--camera', path.join(examples, 'camera_wide_1280x800.json'),
    '--scene', path.join(examples, 'scene_chessboard_calibration.json'),
    '--out', path.join(data, 'imports', 'calib-set')], { stdio: 'ignore', timeout: 120000 });
  const queued = await (await fetch(`${base}/v1/calibrations`, {
    method: 'POST', headers: { ...auth, 'Content-Type': 'application/json' },
    // One model, not the search over four: the page, not model selection, is under test.
    body: JSON.stringify({ folder: 'imports/calib-set', inner_corners: [14, 10], spacing_m: 0.04,
      model: 'LENSMODEL_OPENCV8' }),
  })).json();
  const calibration = await waitFor('the calibration to end', async () => {
    const job = await (await fetch(`${base}/v1/jobs/${queued.id}?wait=20`, { headers: auth })).json();
    return ['queued', 'running'].includes(job.state) ? null : job;
  }, 240000);
  check(calibration.state === 'succeeded', `the calibration of the rendered set (job ${queued.id}) succeeded`);
  await page.click(`#jobs tr[data-job-id="${queued.id}"]`);
  await page.waitForSelector(`#job-panel[data-job-id="${queued.id}"] #job-plots figure`, { timeout: 30000 });
  const report = calibration.result.report;
  const summary = await page.textContent('#job-summary');
  const fov = `field of view ${report.fov_deg.horizontal.toFixed(2)} ± ${report.sigma_1.fov_deg.horizontal.toFixed(2)} x ` +
    `${report.fov_deg.vertical.toFixed(2)} ± ${report.sigma_1.fov_deg.vertical.toFixed(2)} deg`;
  check(summary.includes(`lens model ${report.lensmodel}`) &&
    summary.includes(`RMS reprojection error ${report.residuals.rms_px.toFixed(3)} px over ${report.views.used} of ${report.views.total} views`),
  `the calibration's page gives its model and RMS (${report.lensmodel}, ${report.residuals.rms_px.toFixed(3)} px)`);
  check(summary.includes(fov) && summary.includes(`focal length ${report.fx_px.toFixed(2)} ± ${report.sigma_1.fx_px.toFixed(2)}`),
    `and its FOV and focal length with their 1-sigma errors: "${fov}"`);
  await page.waitForFunction(() => {
    const img = document.querySelector('#job-plots figure[data-name="uncertainty.png"] img.plot');
    return img && img.complete && img.naturalWidth > 0;
  }, null, { timeout: 30000 });
  check(true, 'and its projection uncertainty map');
  await page.locator('#job-panel').screenshot({ path: path.join(screenshots, 'result-calibration.png') });

  check(consoleErrors.length === 0, `no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
}

await run(main);
