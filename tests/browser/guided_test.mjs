// The guided calibration panel in a real browser. camlabd runs the 1280x800 virtual camera
// looking at a chessboard (14 x 10 inner corners, 40 mm) that stays where it is. From the
// page: a session is started, a view taken; the panel must show the suggestion camlabd
// made (the same words as GET /v1/calibration-sessions/{id}) and draw the suggested board
// over the live view; the same view taken again is refused as a repeat of view 0, and the
// page says so with camlabd's code. Every wait is bounded.
//
//   node guided_test.mjs CAMLABD_PATH SOURCE_DIR
import path from 'node:path';
import { check, loggedInPage, run, screenshots, startDaemon } from './harness.mjs';

const [camlabd, sourceDir] = process.argv.slice(2);

async function main() {
  const examples = path.join(sourceDir || '', 'mock_device', 'examples');
  const { base, token, auth } = await startDaemon(camlabd, ['--no-scan',
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
  check(consoleErrors.length === 0, `no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
}

await run(main);
