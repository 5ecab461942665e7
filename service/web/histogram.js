// The histogram of a frame's raw DN (GET /v1/cameras/{id}/histogram): one line per channel
// (R, Gr, Gb, B for a Bayer mosaic; Y for mono), counts on a linear or log scale, the black
// level and the white level marked, and per channel the mean and the share clipped.

import { esc } from './api.js';

const COLOURS = { Y: '#d0d0d0', R: '#ff5050', Gr: '#40d040', Gb: '#a0ff60', G: '#40d040', B: '#5080ff' };

export function drawHistogram(canvas, table, histogram, { log }) {
  const ctx = canvas.getContext('2d');
  const width = canvas.width;
  const height = canvas.height;
  const left = 44, right = 8, top = 8, bottom = 32;
  const plotW = width - left - right, plotH = height - top - bottom;
  const fullScale = histogram.bins * histogram.bin_width_dn;
  const x = (dn) => left + (dn / fullScale) * plotW;
  let peak = 1;
  for (const c of histogram.channels) for (const n of c.counts) peak = Math.max(peak, n);
  const scale = (n) => (log ? Math.log10(1 + n) / Math.log10(1 + peak) : n / peak);
  const y = (n) => top + plotH * (1 - scale(n));

  ctx.fillStyle = '#15181c';
  ctx.fillRect(0, 0, width, height);
  ctx.strokeStyle = '#444';
  ctx.strokeRect(left, top, plotW, plotH);

  // Black and white levels: the span the signal can use.
  ctx.setLineDash([4, 3]);
  for (const [dn, colour, label] of [
    [histogram.black_level_dn, '#9aa', 'black'], [histogram.white_level_dn, '#f66', 'white']]) {
    ctx.strokeStyle = colour;
    ctx.beginPath();
    ctx.moveTo(x(dn), top);
    ctx.lineTo(x(dn), top + plotH);
    ctx.stroke();
    ctx.fillStyle = colour;
    ctx.font = '11px sans-serif';
    ctx.fillText(`${label} ${dn}`, Math.min(x(dn) + 3, width - 70), top + 12);
  }
  ctx.setLineDash([]);

  for (const c of histogram.channels) {
    ctx.strokeStyle = COLOURS[c.channel] || '#fff';
    ctx.beginPath();
    c.counts.forEach((n, i) => {
      const px = x((i + 0.5) * histogram.bin_width_dn);
      if (i === 0) ctx.moveTo(px, y(n)); else ctx.lineTo(px, y(n));
    });
    ctx.stroke();
  }

  // Samples at or above the white level pile up in the bin under its dashed line, where a
  // line alone would hide them: each channel's clipped bin gets a triangle at its count
  // and the share clipped beside it.
  let labelY = top + 26;
  const whiteBin = Math.min(histogram.bins - 1, Math.floor(histogram.white_level_dn / histogram.bin_width_dn));
  for (const c of histogram.channels) {
    if (!c.clipped_high) continue;
    const n = c.counts.slice(whiteBin).reduce((a, b) => a + b, 0);
    const px = x((whiteBin + 0.5) * histogram.bin_width_dn);
    const py = y(n);
    ctx.fillStyle = COLOURS[c.channel] || '#fff';
    ctx.strokeStyle = '#f66';
    ctx.beginPath();
    ctx.moveTo(px, py - 2);
    ctx.lineTo(px - 6, py - 12);
    ctx.lineTo(px + 6, py - 12);
    ctx.closePath();
    ctx.fill();
    ctx.stroke();
    ctx.font = '11px sans-serif';
    ctx.textAlign = 'right';
    ctx.fillText(`${c.channel} ${(100 * c.clipped_high_fraction).toFixed(2)} % clipped`, px - 8, labelY);
    labelY += 13;
  }
  ctx.textAlign = 'left';
  canvas.dataset.clippedMarked = String(histogram.channels.filter((c) => c.clipped_high).length);

  // DN ticks under the axis (the last one right-aligned to stay inside), the unit below.
  ctx.fillStyle = '#aaa';
  ctx.font = '11px sans-serif';
  for (let k = 0; k <= 4; k++) {
    const dn = Math.round((k / 4) * fullScale);
    ctx.textAlign = k === 0 ? 'left' : k === 4 ? 'right' : 'center';
    ctx.fillText(String(dn), x(dn), top + plotH + 13);
  }
  ctx.textAlign = 'center';
  ctx.fillText('raw DN', left + plotW / 2, height - 3);
  ctx.save();
  ctx.translate(12, top + plotH / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.fillText(log ? 'log count' : 'count', 0, 0);
  ctx.restore();
  ctx.textAlign = 'left';

  const rows = histogram.channels.map((c) =>
    `<tr><th>${esc(c.channel)}</th><td>mean ${c.mean_dn.toFixed(1)} DN</td>` +
    `<td>${c.min_dn}..${c.max_dn}</td>` +
    `<td class="${c.clipped_high ? 'warn' : ''}">${(100 * c.clipped_high_fraction).toFixed(2)} % clipped</td>` +
    `<td>${(100 * c.at_or_below_black_fraction).toFixed(2)} % at black</td></tr>`);
  table.innerHTML =
    `<tr><td colspan="5" class="muted">frame ${histogram.sequence} · ${esc(histogram.format.fourcc.trim())} ` +
    `${histogram.format.width} x ${histogram.format.height} · ${histogram.bit_depth} bits` +
    `${histogram.linear ? '' : ' · not linear (JPEG)'} · bins of ${histogram.bin_width_dn} DN</td></tr>` +
    rows.join('');
  // For scripts and tests that watch the page.
  canvas.dataset.sequence = String(histogram.sequence);
  canvas.dataset.mean = String(histogram.channels[0].mean_dn);
}
