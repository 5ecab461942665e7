// Jobs: the list with live progress (server-sent events from GET /v1/events, read with
// fetch so they carry the token), and a job's page: its frames as thumbnails with the
// settings in effect, the analyses that fit it, and the plots of analysis and calibration
// jobs (linearity, photon transfer, CoC against f-number, V-curve, depth map, residuals,
// uncertainty).

import { api, esc, imageUrl, readEvents, request, sleep } from './api.js';
import { drawChart } from './charts.js';
import { resultLines } from './summaries.js';

const FINAL = new Set(['succeeded', 'failed', 'cancelled', 'interrupted', 'device_lost']);
// What each capture kind can be analysed for (POST /v1/analyses).
const ANALYSES = {
  bracket: [['exposure', 'Analyse exposure: linearity, photon transfer, HDR']],
  focus_stack: [['focus', 'Analyse the focus stack: depth from focus'],
    ['defocus', 'Analyse defocus: V-curve of blur against focus']],
  aperture_series: [['defocus', 'Analyse defocus: CoC against f-number'],
    ['sfr', 'Analyse SFR: MTF50 of every edge per f-stop']],
  lens_map: [['lensmap', 'Analyse the lens map: best-focus surface, tilt, curvature per f-stop'],
    ['sfr', 'Analyse SFR: MTF50 of every edge per frame']],
  single: [],
};
const MAX_THUMBNAILS = 24;

function source(job) {
  if (job.camera_id) return job.camera_id;
  const r = job.request || {};
  return r.source_job ? `job ${r.source_job}` : r.source_folder || '';
}

function progressText(job) {
  const p = job.progress || {};
  if (!p.frames_total) return job.state === 'running' ? 'working...' : '';
  return `${p.frames_done} / ${p.frames_total} frames`;
}

export class JobsPanel {
  constructor(elements) {
    // {tbody, panel, title, summary, actions, error, plots, frames, onStateChange(change)}
    this.e = elements;
    this.jobs = new Map();
    this.openJob = null;
    this.urls = [];  // object URLs of the open job's images
    this.controller = null;
    // The job and state whose plots and frames the panel holds, and the rebuild under way.
    this.shownKey = null;
    this.showGeneration = 0;
  }

  async start() {
    this.stop();
    this.controller = new AbortController();
    await this.reload();
    this.listen(this.controller.signal);
  }

  stop() {
    if (this.controller) this.controller.abort();
    this.controller = null;
  }

  async reload() {
    const { jobs } = await api('/v1/jobs?limit=50');
    this.jobs = new Map(jobs.map((j) => [j.id, j]));
    this.render();
  }

  async listen(signal) {
    while (!signal.aborted) {
      try {
        await readEvents('/v1/events', signal, (type, data) => this.onEvent(type, data));
      } catch (error) {
        if (signal.aborted) return;
      }
      await sleep(2000);
      if (!signal.aborted) await this.reload().catch(() => {});
    }
  }

  async onEvent(type, change) {
    if (type === 'resync') return this.reload();
    if (type !== 'job') return;
    const known = this.jobs.get(change.id);
    if (!known || known.state !== change.state) this.e.onStateChange(change);
    if (!known || FINAL.has(change.state) || known.state !== change.state) {
      // A new job, or one that changed state: read it whole (its result, its error).
      const job = await api(`/v1/jobs/${change.id}`).catch(() => null);
      if (job) this.jobs.set(job.id, job);
    } else {
      // A progress report: the event carries the counts the job record nests in "progress".
      known.progress = {
        frames_done: change.frames_done, frames_total: change.frames_total,
        frames_discarded: change.frames_discarded,
        fraction: change.frames_total ? change.frames_done / change.frames_total : 0,
      };
    }
    this.render();
    if (this.openJob === change.id && (FINAL.has(change.state) || !known)) this.show(change.id);
    else if (this.openJob === change.id) this.renderSummary(this.jobs.get(change.id));
  }

  added(job) {
    this.jobs.set(job.id, job);
    this.render();
  }

  // The table keeps each job's row and rewrites its cells' text: it is rendered on every
  // progress event (a capture's every frame), and a row rebuilt between a click's press and
  // release never received the click.
  render() {
    const rows = [...this.jobs.values()].sort((a, b) => b.id - a.id).slice(0, 50);
    const kept = new Map([...this.e.tbody.children].map((tr) => [tr.dataset.jobId, tr]));
    const setText = (element, text) => {
      if (element.textContent !== text) element.textContent = text;
    };
    const trs = rows.map((job) => {
      let tr = kept.get(String(job.id));
      if (!tr) {
        tr = document.createElement('tr');
        tr.dataset.jobId = job.id;
        tr.innerHTML = '<td></td><td></td><td></td><td></td>' +
          '<td><progress max="1"></progress> <span></span></td><td></td>';
        tr.addEventListener('click', () => this.show(job.id));
      }
      tr.dataset.state = job.state;
      tr.className = `state-${job.state}${job.id === this.openJob ? ' open' : ''}`;
      const kind = job.kind === 'capture' ? `capture: ${(job.request || {}).kind}`
        : job.kind === 'analysis' ? `analysis: ${(job.request || {}).analysis}` : job.kind;
      const cells = tr.children;
      setText(cells[0], String(job.id));
      setText(cells[1], kind);
      setText(cells[2], source(job));
      setText(cells[3], job.state);
      cells[4].querySelector('progress').value = Math.min(1, (job.progress || {}).fraction || 0);
      setText(cells[4].querySelector('span'), progressText(job));
      setText(cells[5], (job.created_at || '').replace('T', ' ').slice(0, 19));
      return tr;
    });
    const children = this.e.tbody.children;
    if (trs.length !== children.length || trs.some((tr, k) => children[k] !== tr))
      this.e.tbody.replaceChildren(...trs);
  }

  renderSummary(job) {
    if (!job) return;
    this.e.title.textContent = `Job ${job.id}: ${job.kind}` +
      `${job.request && job.request.kind ? ` (${job.request.kind})` : ''} · ${job.state}`;
    this.e.panel.dataset.state = job.state;
    const lines = [{ text: progressText(job) }, ...(FINAL.has(job.state) ? resultLines(job) : [])];
    // The text is rewritten on every progress event (a capture's every frame); the cancel
    // button is kept while its job runs. Rebuilt with the text, a click whose press and
    // release fell either side of a rebuild was lost: the capture ran on to its end.
    let text = this.e.summary.querySelector(':scope > .summary-text');
    if (!text) {
      text = document.createElement('div');
      text.className = 'summary-text';
      this.e.summary.replaceChildren(text);
    }
    text.innerHTML = lines.filter((l) => l.text)
      .map((l) => `<p${l.warn ? ' class="warn"' : ''}>${esc(l.text)}</p>`).join('');
    const button = this.e.summary.querySelector(':scope > #job-cancel');
    if (FINAL.has(job.state)) {
      if (button) button.remove();
    } else if (!button || button.dataset.jobId !== String(job.id)) {
      if (button) button.remove();
      this.e.summary.append(this.cancelButton(job));
    } else if (!button.disabled) {
      button.textContent = job.state === 'queued' ? 'Cancel (queued)' : 'Cancel';
    }
  }

  // DELETE /v1/jobs/{id}: a queued job ends at once, a running capture between frames (the
  // frames kept so far stay), a running calibration or analysis at its next check.
  cancelButton(job) {
    const button = document.createElement('button');
    button.type = 'button';
    button.id = 'job-cancel';
    button.dataset.jobId = String(job.id);
    button.textContent = job.state === 'queued' ? 'Cancel (queued)' : 'Cancel';
    button.addEventListener('click', async () => {
      button.disabled = true;
      this.e.error.textContent = '';
      try {
        await api(`/v1/jobs/${job.id}`, { method: 'DELETE' });
        button.textContent = 'Cancelling...';
      } catch (error) {
        this.e.error.textContent = error.message;
        button.disabled = false;
      }
    });
    return button;
  }

  clearImages() {
    for (const url of this.urls) URL.revokeObjectURL(url);
    this.urls = [];
  }

  // Events can ask for the same job twice at once (its end reported by the event stream
  // and again by a reload): a finished job already on the panel, or being put there, keeps
  // its plots and frames (rebuilding them would make them flicker, and two rebuilds at once
  // would show each twice); a newer rebuild stops an older one at its next step.
  async show(id) {
    this.openJob = id;
    this.render();
    const job = await api(`/v1/jobs/${id}`);
    this.jobs.set(id, job);
    if (this.openJob !== id) return;
    this.e.panel.hidden = false;
    this.e.panel.dataset.jobId = id;
    this.e.error.textContent = '';
    this.renderSummary(job);
    const key = `${id}:${job.state}`;
    if (FINAL.has(job.state) && this.shownKey === key) return;
    this.shownKey = key;
    const generation = ++this.showGeneration;
    const current = () => generation === this.showGeneration && this.openJob === id;
    this.clearImages();
    this.e.actions.replaceChildren();
    this.e.plots.replaceChildren();
    this.e.frames.replaceChildren();
    if (job.kind === 'capture' && FINAL.has(job.state)) {
      this.offerAnalyses(job);
      this.offerCalibration(job);
    }
    try {
      if (job.kind !== 'capture' && FINAL.has(job.state)) await this.showPlots(job, current);
      if (job.kind === 'capture' && job.state !== 'queued' && current())
        await this.showFrames(job, current);
      if (current()) await this.showFiles(job);
    } catch (error) {
      if (current()) this.shownKey = null;  // half shown: the next show builds it again
      throw error;
    }
  }

  // Every file the job wrote, each a download of the file as stored (GET /v1/jobs/{id}/files;
  // fetched with the token, then saved from an object URL).
  async showFiles(job) {
    const list = this.e.files.querySelector('ul');
    list.replaceChildren();
    this.e.files.hidden = true;
    if (!FINAL.has(job.state)) return;
    const { files } = await api(`/v1/jobs/${job.id}/files`).catch(() => ({ files: [] }));
    if (this.openJob !== job.id || !files.length) return;
    this.e.files.querySelector('summary').textContent = `Files (${files.length})`;
    for (const file of files) {
      const item = document.createElement('li');
      const link = document.createElement('a');
      link.href = '#';
      link.dataset.path = file.path;
      link.textContent = file.path;
      link.addEventListener('click', async (event) => {
        event.preventDefault();
        try {
          const blob = await (await request(file.url)).blob();
          const save = document.createElement('a');
          save.href = URL.createObjectURL(blob);
          save.download = file.path.split('/').pop();
          save.click();
          setTimeout(() => URL.revokeObjectURL(save.href), 10000);
        } catch (error) {
          this.e.error.textContent = error.message;
        }
      });
      item.append(link, ` ${file.bytes} bytes`);
      list.append(item);
    }
    this.e.files.hidden = false;
  }

  // A calibration of a capture's frames (views of a chessboard or ChArUco board): the
  // board's inner corners and square size, as POST /v1/calibrations takes them.
  offerCalibration(job) {
    const form = document.createElement('form');
    form.className = 'inline';
    form.innerHTML =
      '<label>Calibrate: inner corners <input name="corners" value="14x10" size="6"></label> ' +
      '<label>square <input name="spacing" value="0.04" size="6"> m</label> ' +
      '<label>detector <select name="detector"><option>auto</option>' +
      '<option>markers</option><option>opencv</option><option>mrgingham</option></select></label> ' +
      '<button type="submit">Calibrate</button>';
    form.addEventListener('submit', async (event) => {
      event.preventDefault();
      this.e.error.textContent = '';
      const corners = form.corners.value.split(/[x, ]+/).map(Number);
      try {
        const queued = await api('/v1/calibrations', {
          method: 'POST',
          body: { job: job.id, inner_corners: corners, spacing_m: Number(form.spacing.value),
            detector: form.detector.value },
        });
        this.added(queued);
        await this.show(queued.id);
      } catch (error) {
        this.e.error.textContent = error.message;
      }
    });
    this.e.actions.append(form);
  }

  offerAnalyses(job) {
    for (const [analysis, label] of ANALYSES[(job.request || {}).kind] || []) {
      const button = document.createElement('button');
      button.type = 'button';
      button.textContent = label;
      button.dataset.analysis = analysis;
      button.addEventListener('click', async () => {
        button.disabled = true;
        this.e.error.textContent = '';
        try {
          const queued = await api('/v1/analyses', { method: 'POST', body: { kind: analysis, job: job.id } });
          this.added(queued);
          await this.show(queued.id);
        } catch (error) {
          this.e.error.textContent = error.message;
          button.disabled = false;
        }
      });
      this.e.actions.append(button);
    }
  }

  // Each plot as an interactive chart (uPlot, from the plot's data) where it is one of
  // points and lines, else gnuplot's PNG; the PNG of a chart is a click away.
  async showPlots(job, current) {
    const { plots: all } = await api(`/v1/jobs/${job.id}/plots`);
    if (!current()) return;
    // Raw-DN images are data, not pictures (their display-mapped twin is shown); they are
    // among the job's files to download.
    const plots = all.filter((plot) => !plot.name.endsWith('_raw.png'));
    for (const plot of plots) {
      const figure = document.createElement('figure');
      figure.dataset.name = plot.name;
      this.e.plots.append(figure);
      const chart = plot.data ? await api(plot.data).catch(() => null) : null;
      if (!current()) return;
      const holder = document.createElement('div');
      holder.className = 'chart';
      figure.append(holder);
      if (chart && drawChart(holder, chart)) {
        figure.dataset.drawn = 'chart';
        const toggle = document.createElement('button');
        toggle.type = 'button';
        toggle.textContent = 'PNG';
        toggle.title = "gnuplot's drawing of the same data, as --plots writes it";
        toggle.addEventListener('click', async () => {
          toggle.disabled = true;
          figure.append(await this.plotImage(job, plot));
        });
        figure.append(toggle);
      } else {
        holder.remove();
        figure.dataset.drawn = 'image';
        const image = await this.plotImage(job, plot);
        if (!current()) return;
        figure.append(image);
      }
      const caption = document.createElement('figcaption');
      caption.textContent = plot.name.replace(/\.png$/, '').replaceAll('_', ' ');
      figure.append(caption);
    }
    if (!plots.length && job.state === 'succeeded')
      this.e.plots.textContent = 'This job drew no plots.';
  }

  async plotImage(job, plot) {
    const img = document.createElement('img');
    img.className = 'plot';
    img.alt = plot.name;
    img.dataset.name = plot.name;
    const url = await imageUrl(plot.image);
    this.urls.push(url);
    img.src = url;
    return img;
  }

  async showFrames(job, current) {
    const { frames } = await api(`/v1/jobs/${job.id}/frames`);
    if (!current()) return;
    const shown = frames.slice(0, MAX_THUMBNAILS);
    for (const frame of shown) {
      const figure = document.createElement('figure');
      const img = document.createElement('img');
      img.className = 'thumbnail';
      img.alt = `frame ${frame.index}`;
      img.dataset.index = String(frame.index);
      img.title = 'Open in the viewer: zoom, raw DN under the cursor, ROI statistics';
      img.addEventListener('click', () => this.e.onOpenFrame(job.id, frame.index));
      const caption = document.createElement('figcaption');
      figure.append(img, caption);
      this.e.frames.append(figure);
      const [url, meta] = await Promise.all([
        imageUrl(`/v1/jobs/${job.id}/frames/${frame.index}/thumbnail?width=160&clipping=1`),
        api(frame.meta)]);
      this.urls.push(url);
      if (!current()) return;
      img.src = url;
      const s = meta.settings || {};
      const parts = [`#${frame.index}`];
      if (s.exposure_us !== undefined) parts.push(`${(s.exposure_us / 1000).toFixed(2)} ms`);
      if (s.gain !== undefined) parts.push(`gain ${Number(s.gain).toFixed(2)}`);
      if (s.f_number !== undefined) parts.push(`f/${s.f_number}`);
      if (s.focus_position !== undefined) parts.push(`focus ${s.focus_position}`);
      caption.textContent = parts.join(' · ');
      caption.title = JSON.stringify(s);
    }
    if (frames.length > shown.length) {
      const more = document.createElement('p');
      more.className = 'muted';
      more.textContent = `${frames.length - shown.length} more frames (GET /v1/jobs/${job.id}/frames)`;
      this.e.frames.append(more);
    }
  }
}

