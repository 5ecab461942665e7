// The live view: reads GET /v1/cameras/{id}/live (multipart/x-mixed-replace, one JPEG per
// part with its Content-Length and frame headers) and draws each frame on a canvas.
// Reconnects after a pause when the stream ends (the camera was unplugged, camlabd
// restarted); shows the rate of the frames shown, which holds the cap while the camera
// keeps up. The rate is taken on the camera's clock (X-Frame-Timestamp-Ns), not on arrival:
// a busy browser or network delivers frames in bunches, and arrival times would then show
// a rate above the cap that camlabd never sent.

import { chunks, enc, sleep } from './api.js';

const HEADER_END = new Uint8Array([13, 10, 13, 10]);

function indexOf(buffer, pattern, from) {
  outer: for (let i = from; i <= buffer.length - pattern.length; i++) {
    for (let j = 0; j < pattern.length; j++) if (buffer[i + j] !== pattern[j]) continue outer;
    return i;
  }
  return -1;
}

function concat(a, b) {
  if (!a.length) return b;
  const out = new Uint8Array(a.length + b.length);
  out.set(a, 0);
  out.set(b, a.length);
  return out;
}

// Splits a multipart stream into parts: yields {headers, body} for each.
export async function* multipartParts(source) {
  let buffer = new Uint8Array(0);
  const ascii = new TextDecoder('ascii');
  for await (const chunk of source) {
    buffer = concat(buffer, chunk);
    for (;;) {
      const headerEnd = indexOf(buffer, HEADER_END, 0);
      if (headerEnd < 0) break;
      const headers = {};
      for (const line of ascii.decode(buffer.subarray(0, headerEnd)).split('\r\n')) {
        const colon = line.indexOf(':');
        if (colon > 0) headers[line.slice(0, colon).trim().toLowerCase()] = line.slice(colon + 1).trim();
      }
      const length = Number(headers['content-length']);
      if (!Number.isFinite(length)) throw new Error('live view: a part without Content-Length');
      const start = headerEnd + 4;
      if (buffer.length < start + length + 2) break;  // the body and its CRLF are still coming
      yield { headers, body: buffer.slice(start, start + length) };
      buffer = buffer.slice(start + length + 2);
    }
  }
}

export class LiveView {
  constructor(canvas, status) {
    this.canvas = canvas;
    this.status = status;
    this.context = canvas.getContext('2d');
    this.controller = null;
    this.arrivals = [];  // camera timestamps (ms) of the frames of the last 3 s, for the rate
    this.frames = 0;
    this.overlay = null;  // (context, width, height) => draws over each frame shown
  }

  // (Re)starts the view of `cameraId` with `options` {fps, peaking, peakingThreshold,
  // clipping, width}.
  start(cameraId, options) {
    this.stop();
    const controller = new AbortController();
    this.controller = controller;
    const query = new URLSearchParams({
      fps: options.fps, width: options.width || 640,
      peaking: options.peaking ? 1 : 0, clipping: options.clipping ? 1 : 0,
      peaking_threshold: options.peakingThreshold || 150,
    });
    this.loop(`/v1/cameras/${enc(cameraId)}/live?${query}`, controller.signal, options.fps);
  }

  stop() {
    if (this.controller) this.controller.abort();
    this.controller = null;
    this.arrivals = [];
  }

  async loop(path, signal, cap) {
    while (!signal.aborted) {
      try {
        this.status.textContent = 'Connecting...';
        for await (const part of multipartParts(chunks(path, signal))) {
          await this.show(part, cap);
          if (signal.aborted) return;
        }
        this.status.textContent = 'The stream ended; reconnecting...';
      } catch (error) {
        if (signal.aborted) return;
        this.status.textContent = `No live view: ${error.message}; retrying...`;
      }
      await sleep(1500);
    }
  }

  async show(part, cap) {
    const bitmap = await createImageBitmap(new Blob([part.body], { type: 'image/jpeg' }));
    if (this.canvas.width !== bitmap.width || this.canvas.height !== bitmap.height) {
      this.canvas.width = bitmap.width;
      this.canvas.height = bitmap.height;
    }
    this.context.drawImage(bitmap, 0, 0);
    bitmap.close();
    // Whatever a panel draws over the picture (the guided calibration's next board).
    if (this.overlay) this.overlay(this.context, this.canvas.width, this.canvas.height);
    this.canvas.dataset.overlay = this.overlay ? '1' : '';
    const repeated = part.headers['x-frame-repeated'] === '1';
    const stampMs = Number(part.headers['x-frame-timestamp-ns']) / 1e6;
    if (!repeated) {
      this.frames += 1;
      // A camera that restarted its clock begins a new window.
      const last = this.arrivals[this.arrivals.length - 1];
      if (!Number.isFinite(stampMs) || (last !== undefined && stampMs <= last)) this.arrivals = [];
      if (Number.isFinite(stampMs)) this.arrivals.push(stampMs);
    }
    const newest = this.arrivals[this.arrivals.length - 1];
    while (this.arrivals.length && newest - this.arrivals[0] > 3000) this.arrivals.shift();
    const rate = this.arrivals.length > 1
      ? (this.arrivals.length - 1) / ((this.arrivals[this.arrivals.length - 1] - this.arrivals[0]) / 1000)
      : 0;
    const sequence = part.headers['x-frame-sequence'];
    // For scripts and tests that watch the page.
    this.canvas.dataset.frames = String(this.frames);
    this.canvas.dataset.sequence = sequence;
    this.status.textContent =
      `frame ${sequence} · ${rate.toFixed(1)} frames/s (cap ${cap}) · ` +
      `${part.headers['x-frame-width']} x ${part.headers['x-frame-height']} px shown` +
      (repeated ? ' · no new frame (camera idle or busy)' : '');
  }
}
