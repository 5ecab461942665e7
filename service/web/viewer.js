// The frame viewer: one stored frame of a capture, zoomed and panned to 1:1 and beyond,
// with the raw DN under the cursor and the statistics of a region drawn on it.
//
// The picture is the frame's display rendering (GET .../thumbnail at the frame's full
// width); every number shown comes from the stored raw DN (GET .../region), never from
// the picture's 8-bit values. A Bayer frame shows the 2x2 filter cell under the cursor
// (R, Gr, Gb, B), the pixel's own site marked; the ROI's statistics are per channel.
//
// Mouse: drag pans, the wheel zooms about the cursor, shift-drag (or drag with "Draw ROI"
// on) draws the region. Zoom is in frame pixels per screen pixel: 1:1 shows each frame
// pixel on one screen pixel; beyond 8x the pixel grid is drawn.

import { api, esc, request } from './api.js';

const MIN_ZOOM = 1 / 16;
const MAX_ZOOM = 64;
const GRID_ZOOM = 8;

function formatNumber(value, digits) {
  return value === null || value === undefined ? '-' : Number(value).toFixed(digits);
}

export class FrameViewer {
  // elements: {panel, title, canvas, zoom, pixel, roi, roiMode, fit, one, zoomIn, zoomOut, close, error}
  constructor(elements) {
    this.e = elements;
    this.context = elements.canvas.getContext('2d');
    this.image = null;        // the display picture (ImageBitmap)
    this.frame = null;        // {jobId, index, width, height, base}
    this.zoom = 1;
    this.origin = { x: 0, y: 0 };  // the frame point at the canvas's top left
    this.roi = null;          // {x, y, width, height} in frame pixels
    this.drag = null;
    this.pending = null;      // the latest cursor region asked for while one is in flight
    this.busy = false;
    this.bind();
  }

  bind() {
    const c = this.e.canvas;
    c.addEventListener('wheel', (event) => {
      event.preventDefault();
      const point = this.toFrame(event);
      this.setZoom(this.zoom * (event.deltaY < 0 ? 1.25 : 0.8), point, this.offsetOf(event));
    }, { passive: false });
    c.addEventListener('mousedown', (event) => {
      if (!this.frame) return;
      const roi = event.shiftKey || this.e.roiMode.checked;
      this.drag = { roi, start: this.toFrame(event), origin: { ...this.origin }, at: this.offsetOf(event) };
    });
    window.addEventListener('mouseup', (event) => {
      if (!this.drag) return;
      const drag = this.drag;
      this.drag = null;
      if (drag.roi) this.finishRoi(drag.start, this.toFrame(event));
    });
    c.addEventListener('mousemove', (event) => {
      if (!this.frame) return;
      if (this.drag && !this.drag.roi) {
        const at = this.offsetOf(event);
        this.origin = { x: this.drag.origin.x - (at.x - this.drag.at.x) / this.zoom,
          y: this.drag.origin.y - (at.y - this.drag.at.y) / this.zoom };
        this.draw();
        return;
      }
      if (this.drag && this.drag.roi) {
        this.roi = this.rectOf(this.drag.start, this.toFrame(event));
        this.draw();
      }
      this.lookUnderCursor(this.toFrame(event));
    });
    this.e.fit.addEventListener('click', () => this.fit());
    this.e.one.addEventListener('click', () => this.setZoom(1, this.centre(), this.canvasCentre()));
    this.e.zoomIn.addEventListener('click', () => this.setZoom(this.zoom * 2, this.centre(), this.canvasCentre()));
    this.e.zoomOut.addEventListener('click', () => this.setZoom(this.zoom / 2, this.centre(), this.canvasCentre()));
    this.e.close.addEventListener('click', () => this.close());
  }

  // Opens frame `index` of capture job `jobId`.
  async open(jobId, index) {
    this.close();
    const base = `/v1/jobs/${jobId}/frames/${index}`;
    this.e.panel.hidden = false;
    this.e.error.textContent = '';
    this.e.title.textContent = `Frame ${index} of job ${jobId}`;
    try {
      // The frame's size and format, from the raw values themselves.
      const first = await api(`${base}/region?x=0&y=0&width=1&height=1`);
      this.frame = { jobId, index, base, width: first.frame_width, height: first.frame_height,
        format: first };
      const picture = await request(`${base}/thumbnail?width=${Math.min(4096, first.frame_width)}`);
      this.image = await createImageBitmap(await picture.blob());
      this.e.canvas.dataset.frameWidth = String(first.frame_width);
      this.e.canvas.dataset.frameHeight = String(first.frame_height);
      this.e.title.textContent = `Frame ${index} of job ${jobId} · ${first.frame_width} x ${first.frame_height} px · ` +
        `${first.pixel_format}${first.cfa_pattern ? ` (${first.cfa_pattern})` : ''} · ${first.bit_depth} bits · ` +
        `black ${first.black_level_dn}, white ${first.white_level_dn} DN${first.linear ? '' : ' · not linear (JPEG)'}`;
      this.fit();
      this.e.panel.scrollIntoView({ block: 'nearest' });
    } catch (error) {
      this.e.error.textContent = error.message;
    }
  }

  close() {
    if (this.image) this.image.close();
    this.image = null;
    this.frame = null;
    this.roi = null;
    this.e.pixel.textContent = '';
    delete this.e.pixel.dataset.x;
    this.e.roi.replaceChildren();
    this.e.panel.hidden = true;
  }

  offsetOf(event) {
    const r = this.e.canvas.getBoundingClientRect();
    return { x: (event.clientX - r.left) * (this.e.canvas.width / r.width),
      y: (event.clientY - r.top) * (this.e.canvas.height / r.height) };
  }

  toFrame(event) {
    const at = this.offsetOf(event);
    return { x: this.origin.x + at.x / this.zoom, y: this.origin.y + at.y / this.zoom };
  }

  centre() {
    return { x: this.origin.x + this.e.canvas.width / 2 / this.zoom,
      y: this.origin.y + this.e.canvas.height / 2 / this.zoom };
  }

  canvasCentre() { return { x: this.e.canvas.width / 2, y: this.e.canvas.height / 2 }; }

  // Zoom to `zoom`, keeping frame point `point` under canvas point `at`.
  setZoom(zoom, point, at) {
    if (!this.frame) return;
    this.zoom = Math.min(MAX_ZOOM, Math.max(MIN_ZOOM, zoom));
    this.origin = { x: point.x - at.x / this.zoom, y: point.y - at.y / this.zoom };
    this.draw();
  }

  fit() {
    if (!this.frame) return;
    const c = this.e.canvas;
    this.zoom = Math.min(c.width / this.frame.width, c.height / this.frame.height);
    this.origin = { x: -(c.width / this.zoom - this.frame.width) / 2,
      y: -(c.height / this.zoom - this.frame.height) / 2 };
    this.draw();
  }

  draw() {
    const ctx = this.context;
    const c = this.e.canvas;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = '#000';
    ctx.fillRect(0, 0, c.width, c.height);
    if (!this.frame || !this.image) return;
    // Frame pixels to canvas pixels; the picture (half size for a mosaic shown demosaiced)
    // stretched over the frame's own pixel grid.
    ctx.setTransform(this.zoom, 0, 0, this.zoom, -this.origin.x * this.zoom, -this.origin.y * this.zoom);
    ctx.imageSmoothingEnabled = this.zoom < 1;
    ctx.drawImage(this.image, 0, 0, this.frame.width, this.frame.height);
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    if (this.zoom >= GRID_ZOOM) this.drawGrid();
    if (this.roi) {
      ctx.strokeStyle = '#ffd400';
      ctx.lineWidth = 1.5;
      ctx.strokeRect((this.roi.x - this.origin.x) * this.zoom, (this.roi.y - this.origin.y) * this.zoom,
        this.roi.width * this.zoom, this.roi.height * this.zoom);
    }
    this.e.zoom.textContent = this.zoom >= 1 ? `${+this.zoom.toFixed(2)}:1` : `1:${+(1 / this.zoom).toFixed(2)}`;
    c.dataset.zoom = String(this.zoom);
  }

  drawGrid() {
    const ctx = this.context;
    const c = this.e.canvas;
    ctx.strokeStyle = 'rgba(128, 128, 128, 0.5)';
    ctx.lineWidth = 1;
    ctx.beginPath();
    const x0 = Math.max(0, Math.floor(this.origin.x));
    const x1 = Math.min(this.frame.width, Math.ceil(this.origin.x + c.width / this.zoom));
    for (let x = x0; x <= x1; x++) {
      const px = Math.round((x - this.origin.x) * this.zoom) + 0.5;
      ctx.moveTo(px, 0);
      ctx.lineTo(px, c.height);
    }
    const y0 = Math.max(0, Math.floor(this.origin.y));
    const y1 = Math.min(this.frame.height, Math.ceil(this.origin.y + c.height / this.zoom));
    for (let y = y0; y <= y1; y++) {
      const py = Math.round((y - this.origin.y) * this.zoom) + 0.5;
      ctx.moveTo(0, py);
      ctx.lineTo(c.width, py);
    }
    ctx.stroke();
  }

  // Frame pixels spanned by two points, inside the frame; at least 1 x 1.
  rectOf(a, b) {
    const clampX = (v) => Math.min(this.frame.width, Math.max(0, v));
    const clampY = (v) => Math.min(this.frame.height, Math.max(0, v));
    const x0 = Math.floor(clampX(Math.min(a.x, b.x)));
    const y0 = Math.floor(clampY(Math.min(a.y, b.y)));
    const x1 = Math.max(x0 + 1, Math.ceil(clampX(Math.max(a.x, b.x))));
    const y1 = Math.max(y0 + 1, Math.ceil(clampY(Math.max(a.y, b.y))));
    return { x: Math.min(x0, this.frame.width - 1), y: Math.min(y0, this.frame.height - 1),
      width: Math.min(x1, this.frame.width) - Math.min(x0, this.frame.width - 1),
      height: Math.min(y1, this.frame.height) - Math.min(y0, this.frame.height - 1) };
  }

  // The DN under the cursor: the pixel, or for a mosaic its 2x2 filter cell. One request
  // in flight; the latest position waits for it.
  lookUnderCursor(point) {
    const x = Math.floor(point.x);
    const y = Math.floor(point.y);
    if (x < 0 || y < 0 || x >= this.frame.width || y >= this.frame.height) return;
    this.pending = { x, y, frame: this.frame };
    if (!this.busy) this.readPending();
  }

  async readPending() {
    this.busy = true;
    while (this.pending) {
      const { x, y, frame } = this.pending;
      this.pending = null;
      const mosaic = Boolean(frame.format.cfa_pattern);
      const cx = mosaic ? x - (x % 2) : x;
      const cy = mosaic ? y - (y % 2) : y;
      const size = mosaic ? 2 : 1;
      try {
        const region = await api(`${frame.base}/region?x=${cx}&y=${cy}&width=${size}&height=${size}`);
        if (frame !== this.frame) break;
        const own = region.samples.find((s) => s.x === x && s.y === y);
        const values = region.samples.map((s) =>
          `${s.x === x && s.y === y && mosaic ? `<b>${esc(s.channel)} ${s.dn}</b>` : `${esc(s.channel)} ${s.dn}`}`);
        this.e.pixel.innerHTML = `x ${x}, y ${y}: ${values.join(' · ')} DN`;
        this.e.pixel.dataset.x = String(x);
        this.e.pixel.dataset.y = String(y);
        this.e.pixel.dataset.dn = String(own ? own.dn : '');
        this.e.pixel.dataset.samples = JSON.stringify(region.samples);
      } catch (error) {
        this.e.error.textContent = error.message;
      }
    }
    this.busy = false;
  }

  async finishRoi(a, b) {
    if (!this.frame) return;
    this.roi = this.rectOf(a, b);
    this.draw();
    const r = this.roi;
    const frame = this.frame;
    try {
      const stats = await api(`${frame.base}/region?x=${r.x}&y=${r.y}&width=${r.width}&height=${r.height}`);
      if (frame !== this.frame) return;
      const rows = stats.channels.map((c) =>
        `<tr data-channel="${esc(c.channel)}"><th>${esc(c.channel)}</th><td>${formatNumber(c.mean_dn, 2)}</td>` +
        `<td>${formatNumber(c.sd_dn, 2)}</td><td>${formatNumber(c.snr, 1)}</td>` +
        `<td>${c.min_dn}..${c.max_dn}</td><td>${c.samples}</td></tr>`);
      this.e.roi.innerHTML =
        `<caption>ROI x ${r.x}, y ${r.y}, ${r.width} x ${r.height} px; SNR = (mean - black ${stats.black_level_dn} DN) / sd</caption>` +
        '<tr><th>channel</th><th>mean [DN]</th><th>sd [DN]</th><th>SNR</th><th>range [DN]</th><th>samples</th></tr>' +
        rows.join('');
      this.e.roi.dataset.rect = JSON.stringify(r);
      this.e.roi.dataset.channels = JSON.stringify(stats.channels);
    } catch (error) {
      this.e.error.textContent = error.message;
    }
  }
}
