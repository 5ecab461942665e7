// The guided calibration panel: a calibration session on the selected camera
// (POST /v1/calibration-sessions), one view at a time. After each view camlabd solves and
// suggests where to put the board next; the panel says it in words and draws the board's
// suggested outline over the live view, and says why a view was refused (no board, a
// repeat of an earlier pose). Finish calibrates on every view taken, as a job.

import { api, esc } from './api.js';

const POLL_MS = 400;
const BUSY = new Set(['capturing', 'solving', 'finishing']);

const fixed = (value, digits) => (Number.isFinite(Number(value)) ? Number(value).toFixed(digits) : '-');

export class GuidedPanel {
  // elements: {form, session, status, suggestion, refusal, take, finish, cancel, error};
  // live: the LiveView (its overlay draws the suggestion); cameraId(): the camera chosen;
  // onFinished(jobId): the session's calibration ended (a job to show).
  constructor(elements, live, cameraId, onFinished) {
    this.e = elements;
    this.live = live;
    this.cameraId = cameraId;
    this.onFinished = onFinished;
    this.session = null;
    this.polling = false;
    this.e.form.addEventListener('submit', (event) => { event.preventDefault(); this.start(); });
    this.e.take.addEventListener('click', () => this.act('views', 'Taking a view...'));
    this.e.finish.addEventListener('click', () => this.act('finish', 'Calibrating on every view...'));
    this.e.cancel.addEventListener('click', () => this.cancel());
  }

  async start() {
    this.e.error.textContent = '';
    const form = this.e.form;
    try {
      const state = await api('/v1/calibration-sessions', {
        method: 'POST',
        body: { camera: this.cameraId(), inner_corners: form.corners.value.split(/[x, ]+/).map(Number),
          spacing_m: Number(form.spacing.value), detector: form.detector.value },
      });
      this.session = state.id;
      this.render(state);
    } catch (error) {
      this.e.error.textContent = error.message;
    }
  }

  async act(action, busyText) {
    if (!this.session) return;
    this.e.error.textContent = '';
    this.setButtons(false);
    this.e.status.textContent = busyText;
    try {
      const state = await api(`/v1/calibration-sessions/${this.session}/${action}`, { method: 'POST' });
      this.render(state);
      await this.poll();
    } catch (error) {
      this.e.error.textContent = error.message;
      this.setButtons(true);
    }
  }

  async cancel() {
    if (!this.session) return;
    await api(`/v1/calibration-sessions/${this.session}`, { method: 'DELETE' }).catch(() => {});
    this.stop();
  }

  stop() {
    this.session = null;
    this.live.overlay = null;
    this.e.session.hidden = true;
    delete this.e.session.dataset.views;
  }

  // Until the view or the finish is done.
  async poll() {
    if (this.polling) return;
    this.polling = true;
    try {
      while (this.session) {
        const state = await api(`/v1/calibration-sessions/${this.session}`);
        this.render(state);
        if (!BUSY.has(state.phase)) break;
        await new Promise((r) => setTimeout(r, POLL_MS));
      }
    } finally {
      this.polling = false;
    }
  }

  setButtons(enabled) {
    for (const b of [this.e.take, this.e.finish]) b.disabled = !enabled;
  }

  render(state) {
    this.e.session.hidden = false;
    const frames = state.frames || [];
    const refused = frames.filter((f) => f.view === null).length;
    const parts = [`session ${state.id} · ${state.phase}`,
      `${state.views_with_board} view(s) taken${refused ? `, ${refused} refused` : ''}`];
    if (state.solution)
      parts.push(`RMS ${fixed(state.solution.rms_px, 3)} px over ${state.solution.views_used} views`);
    if (state.uncertainty)
      parts.push(`worst projection uncertainty ${fixed(state.uncertainty.worst_px, 3)} px at ` +
        `${fixed(state.uncertainty.distance_m, 2)} m (target ${fixed(state.target_uncertainty_px, 2)} px` +
        `${state.target_reached ? ', reached' : ''})`);
    this.e.status.textContent = parts.join(' · ');
    this.e.session.dataset.views = String(state.views_with_board);
    this.e.session.dataset.refused = String(refused);
    this.e.session.dataset.phase = state.phase;

    const s = state.suggestion;
    this.e.suggestion.innerHTML = s
      ? `<b>Next view:</b> ${esc(s.description)}` +
        (s.predicted_worst_px > 0 ? ` (worst ${fixed(s.worst_now_px, 3)} px now, ${fixed(s.predicted_worst_px, 3)} predicted with it)` : '')
      : (state.views_with_board ? '' : 'Take a first view: the board anywhere in the frame, whole.');
    this.e.suggestion.dataset.description = s ? s.description : '';
    this.live.overlay = s && s.outline_px ? (ctx, width) => drawOutline(ctx, width, s) : null;

    const error = state.last_error;
    this.e.refusal.textContent = error ? `${error.code}: ${error.message}` : '';
    this.e.refusal.dataset.code = error ? error.code : '';
    this.setButtons(!BUSY.has(state.phase) && state.phase !== 'ended');
    this.e.finish.disabled = this.e.finish.disabled || !state.views_with_board;
    if (state.phase === 'ended') {
      const id = state.id;
      this.stop();
      this.onFinished(id);
    }
  }
}

// The suggested board: its outer corners joined, over the live picture (`width` px wide
// for an imager of imager_px[0]), with its centre marked.
function drawOutline(ctx, width, s) {
  const scale = width / s.imager_px[0];
  const o = s.outline_px.map((v) => v * scale);
  ctx.save();
  ctx.strokeStyle = '#ffd400';
  ctx.lineWidth = 3;
  ctx.setLineDash([10, 6]);
  ctx.beginPath();
  ctx.moveTo(o[0], o[1]);
  for (let k = 1; k < 4; k++) ctx.lineTo(o[2 * k], o[2 * k + 1]);
  ctx.closePath();
  ctx.stroke();
  ctx.setLineDash([]);
  ctx.beginPath();
  ctx.arc(s.centre_x_px * scale, s.centre_y_px * scale, 6, 0, 2 * Math.PI);
  ctx.stroke();
  ctx.restore();
}
