// The dashboard's start: the login (the token is asked for once per tab and kept in
// session storage), the camera picker, and the panels: live view, histogram, controls,
// capture form, jobs. Everything goes through camlabd's public API (docs/service.md).

import { api, clearToken, enc, onUnauthorized, setToken, token } from './api.js';
import { setUpCaptureForm, showFormats } from './captures.js';
import { ControlsPanel } from './controls.js';
import { drawHistogram } from './histogram.js';
import { JobsPanel } from './jobs.js';
import { LiveView } from './live.js';
import { FrameViewer } from './viewer.js';
import { GuidedPanel } from './guided.js';

const $ = (id) => document.getElementById(id);
const CAMERA_REFRESH_MS = 2000;
const HISTOGRAM_REFRESH_MS = 1000;

const state = {
  cameras: [], cameraId: '', timers: [], paused: false, histogramBusy: false,
  cameraReady: false,  // available and not measuring its latency: frames can be asked for
};

const live = new LiveView($('live-canvas'), $('live-status'));
const controls = new ControlsPanel($('controls'), $('controls-note'), $('controls-error'),
  () => refreshCamera());
const viewer = new FrameViewer({
  panel: $('viewer-panel'), title: $('viewer-title'), canvas: $('viewer-canvas'), zoom: $('viewer-zoom'),
  pixel: $('viewer-pixel'), roi: $('viewer-roi'), roiMode: $('viewer-roi-mode'), fit: $('viewer-fit'),
  one: $('viewer-one'), zoomIn: $('viewer-zoom-in'), zoomOut: $('viewer-zoom-out'),
  close: $('viewer-close'), error: $('viewer-error'),
});

const guided = new GuidedPanel({
  form: $('guided-form'), session: $('guided-session'), status: $('guided-status'),
  suggestion: $('guided-suggestion'), refusal: $('guided-refusal'), take: $('guided-take'),
  finish: $('guided-finish'), cancel: $('guided-cancel'), error: $('guided-error'),
}, live, () => state.cameraId, async (jobId) => {
  await jobs.reload().catch(() => {});
  await jobs.show(jobId).catch(() => {});
});

const jobs = new JobsPanel({
  tbody: $('jobs').tBodies[0], panel: $('job-panel'), title: $('job-title'),
  summary: $('job-summary'), actions: $('job-actions'), error: $('job-error'),
  plots: $('job-plots'), frames: $('job-frames'), files: $('job-files'),
  // A job started or ended: the camera's state (busy, idle) changed with it.
  onStateChange: () => refreshCamera(),
  onOpenFrame: (jobId, index) => viewer.open(jobId, index),
});

function showLogin(message) {
  stopAll();
  $('app').hidden = true;
  $('camera-picker').hidden = true;
  $('logout').hidden = true;
  $('login').hidden = false;
  $('login-error').textContent = message || '';
  $('connection').textContent = '';
  $('token').focus();
}

function stopAll() {
  live.stop();
  jobs.stop();
  viewer.close();
  guided.stop();
  for (const t of state.timers) clearInterval(t);
  state.timers = [];
}

function liveOptions() {
  return {
    fps: Number($('live-fps').value), peaking: $('live-peaking').checked,
    clipping: $('live-clipping').checked, width: 640,
    peakingThreshold: Number($('live-peaking-level').value),
  };
}

function restartLive() {
  if (!state.cameraId || state.paused) return live.stop();
  live.start(state.cameraId, liveOptions());
}

async function refreshCamera() {
  if (!state.cameraId) return;
  try {
    const camera = await api(`/v1/cameras/${enc(state.cameraId)}`);
    controls.render(camera);
    showFormats($('capture-form'), camera.formats);
    const busy = camera.running_job !== null && camera.running_job !== undefined;
    state.cameraReady = camera.available && !camera.measuring_latency;
    $('camera-state').textContent = !camera.available ? 'unavailable'
      : busy ? `capturing (job ${camera.running_job})` : camera.measuring_latency ? 'measuring latency' : 'idle';
    $('connection').textContent = 'connected';
  } catch (error) {
    $('connection').textContent = `camlabd: ${error.message}`;
  }
}

async function refreshHistogram() {
  // Only while frames can come: a request that could only time out is not sent.
  if (!state.cameraId || !state.cameraReady || state.paused || state.histogramBusy || document.hidden) return;
  state.histogramBusy = true;
  try {
    const histogram = await api(`/v1/cameras/${enc(state.cameraId)}/histogram?bins=256`);
    drawHistogram($('histogram-canvas'), $('histogram-stats'), histogram,
      { log: $('histogram-log').checked });
  } catch (error) {
    $('histogram-stats').textContent = `No histogram: ${error.message}`;
  } finally {
    state.histogramBusy = false;
  }
}

async function loadCameras() {
  const { cameras } = await api('/v1/cameras');
  state.cameras = cameras;
  const select = $('camera-select');
  const previous = state.cameraId || sessionStorage.getItem('camlab.camera') || '';
  select.replaceChildren(...cameras.map((c) =>
    new Option(`${c.name || c.id}${c.present === false ? ' (gone)' : ''}`, c.id)));
  state.cameraId = cameras.some((c) => c.id === previous) ? previous : (cameras[0] || {}).id || '';
  select.value = state.cameraId;
  $('camera-picker').hidden = cameras.length === 0;
  if (!cameras.length) $('camera-state').textContent = 'no cameras';
}

async function enter() {
  $('login').hidden = true;
  $('app').hidden = false;
  $('logout').hidden = false;
  await loadCameras();
  restartLive();
  await refreshCamera();
  refreshHistogram();
  await jobs.start();
  state.timers.push(setInterval(refreshCamera, CAMERA_REFRESH_MS));
  state.timers.push(setInterval(refreshHistogram, HISTOGRAM_REFRESH_MS));
}

async function logIn(candidate) {
  setToken(candidate);
  try {
    await api('/v1/cameras');
  } catch (error) {
    clearToken();
    showLogin(error.status === 401 ? 'camlabd refused that token.' : `camlabd: ${error.message}`);
    return;
  }
  await enter();
}

onUnauthorized(() => {
  clearToken();
  showLogin('camlabd no longer accepts the token; log in again.');
});

$('login-form').addEventListener('submit', (event) => {
  event.preventDefault();
  const value = $('token').value.trim();
  $('token').value = '';
  logIn(value);
});
$('logout').addEventListener('click', () => {
  clearToken();
  showLogin('Logged out.');
});
$('camera-select').addEventListener('change', () => {
  state.cameraId = $('camera-select').value;
  sessionStorage.setItem('camlab.camera', state.cameraId);
  restartLive();
  refreshCamera();
});
for (const id of ['live-fps', 'live-peaking', 'live-peaking-level', 'live-clipping']) $(id).addEventListener('change', restartLive);
$('live-pause').addEventListener('click', () => {
  state.paused = !state.paused;
  $('live-pause').textContent = state.paused ? 'Resume' : 'Pause';
  restartLive();
});
$('histogram-log').addEventListener('change', refreshHistogram);
setUpCaptureForm($('capture-form'), $('capture-error'), () => state.cameraId, (job) => {
  jobs.added(job);
  jobs.show(job.id);
});

if (token()) logIn(token()); else showLogin();
