// What a finished job's page opens on: a few lines saying what was measured, what was left
// out and why, and the numbers worth seeing at a glance, each with its unit and, where the
// job gives one, its 1-sigma uncertainty. Each line is {text, warn?}. The analyses' own
// summary (report.summary.text) is the one the CLI prints, shown as is.

const fixed = (value, digits) => (value === null || value === undefined || !Number.isFinite(Number(value))
  ? '-' : Number(value).toFixed(digits));
const pm = (value, sigma, digits) => (sigma === null || sigma === undefined
  ? fixed(value, digits) : `${fixed(value, digits)} ± ${fixed(sigma, digits)}`);
const MAX_TARGETS = 6;

function median(values) {
  if (!values.length) return null;
  const sorted = [...values].sort((a, b) => a - b);
  const mid = sorted.length >> 1;
  return sorted.length % 2 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
}

function captureLines(r) {
  return [`${r.frames_kept} frames kept of ${r.frames_total}; ${r.frames_discarded} discarded while ` +
    `settings settled, ${r.frames_dropped} dropped; ${fixed(r.wall_seconds, 2)} s; ` +
    `control latency ${r.control_latency_frames} frames (${r.control_latency_source})`];
}

function exposureLines(report) {
  const lines = [];
  const lin = report.linearity;
  if (lin && lin.max_abs_error_pct !== undefined)
    lines.push(`linearity: max error ${fixed(lin.max_abs_error_pct, 2)} % of the fit`);
  const ptc = report.photon_transfer;
  if (ptc && ptc.system_gain_dn_per_e !== undefined)
    lines.push(`photon transfer: ${fixed(ptc.system_gain_dn_per_e, 4)} DN/e-, dark noise ` +
      `${fixed(ptc.dark_noise_e, 2)} e-, full well ${fixed(ptc.saturation_capacity_e, 0)} e-`);
  else if (ptc && ptc.error) lines.push({ text: `photon transfer: ${ptc.error}`, warn: true });
  for (const left of (report.summary || {}).left_out || [])
    lines.push(`left out: ${typeof left === 'string' ? left : JSON.stringify(left)}`);
  return lines;
}

function defocusLines(report) {
  const lines = [];
  const targets = report.targets || [];
  const fitted = (t) => (t.coc_vs_aperture && t.coc_vs_aperture.k_px !== undefined) ||
    (t.coc_vs_focus && t.coc_vs_focus.best_position !== undefined);
  // The targets with a fit first; those without are counted, their reasons in the report.
  const shown = targets.filter(fitted).slice(0, MAX_TARGETS);
  for (const t of shown) {
    const a = t.coc_vs_aperture;
    if (a && a.k_px !== undefined)
      lines.push(`${t.name}: CoC = k/N with k ${pm(a.k_px, a.k_sigma_px, 2)} px over ${a.frames_used} ` +
        `frames; sensor ${pm(100 * a.implied_defocus, 100 * a.implied_defocus_sigma, 3)} % off the image distance (|z_s - z_i| / z_i)`);
    const v = t.coc_vs_focus;
    if (v && v.best_position !== undefined)
      lines.push(`${t.name}: V-curve best focus ${pm(v.best_position, v.best_position_sigma, 2)} steps, ` +
        `slope ${pm(v.slope_px_per_step, v.slope_sigma, 4)} px/step over ${v.frames_used} frames` +
        (v.minimum_outside_sweep ? ' (its minimum is outside the sweep)' : ''));
  }
  const more = targets.filter(fitted).length - shown.length;
  if (more > 0) lines.push(`${more} more fitted targets in the report (report.json)`);
  const unfitted = targets.filter((t) => !fitted(t));
  if (unfitted.length) {
    const reasons = new Map();
    for (const t of unfitted) {
      const error = ((t.coc_vs_aperture || t.coc_vs_focus || {}).error || 'no fit').split(':')[0];
      reasons.set(error, (reasons.get(error) || 0) + 1);
    }
    lines.push(`${unfitted.length} target(s) without a fit: ` +
      [...reasons].map(([reason, n]) => `${n} ${reason}`).join(', '));
  }
  return lines;
}

function focusLines(report) {
  const s = report.summary || {};
  return s.depth_valid_share === undefined ? []
    : [`depth map: ${fixed(100 * s.depth_valid_share, 1)} % of the pixels have a depth`];
}

function sfrLines(report) {
  // Edges of a capture are per frame; of one image, at the top level.
  const edges = report.frames ? report.frames.flatMap((f) => f.edges || []) : report.edges || [];
  const mtf50 = edges.map((e) => e.mtf50_cy_px).filter((v) => Number.isFinite(v));
  if (!mtf50.length) return [];
  const lines = [`MTF50 over ${mtf50.length} edge fits: median ${fixed(median(mtf50), 3)} cycles/px, ` +
    `range ${fixed(Math.min(...mtf50), 3)} to ${fixed(Math.max(...mtf50), 3)}`];
  // Each fit's standard error from its own noise, as a share of its MTF50: what one reading
  // is worth (docs/analysis.md, "SFR", step 6).
  const relative = edges.filter((e) => Number.isFinite(e.mtf50_cy_px) && e.mtf50_cy_px > 0 &&
    Number.isFinite(e.mtf50_standard_error_cy_px))
    .map((e) => 100 * e.mtf50_standard_error_cy_px / e.mtf50_cy_px);
  if (relative.length)
    lines.push(`MTF50 standard error: median ${fixed(median(relative), 2)} % of the MTF50 ` +
      `(${relative.length} fits), largest ${fixed(Math.max(...relative), 2)} %`);
  return lines;
}

function lensMapLines(report) {
  const lines = [];
  for (const s of report.surfaces || []) {
    const at = s.at_sensor;
    const e = (at || {}).standard_errors || {};
    const stop = s.f_number ? `f/${s.f_number}` : 'one f-stop';
    lines.push(at
      ? `${stop}: tilt ${pm(at.tilt_x_deg, e.tilt_x_deg, 3)} deg right, ${pm(at.tilt_y_deg, e.tilt_y_deg, 3)} deg down; ` +
        `field curvature ${pm(at.curvature_um, e.curvature_um, 1)} um at the corner` +
        (at.astigmatism_um !== undefined ? `; astigmatism ${pm(at.astigmatism_um, e.astigmatism_um, 1)} um` : '') +
        ` (${s.edges_used} edges)`
      : `${stop}: curvature ${pm(s.curvature_at_corner, (s.standard_errors || {}).curvature_at_corner, 3)} focus steps ` +
        `at the corner (${s.edges_used} edges; no lens extension or pixel pitch for micrometres)`);
  }
  return lines;
}

function calibrationLines(report) {
  const lines = [];
  const sigma = report.sigma_1 || {};
  const views = report.views || {};
  if (report.lensmodel) lines.push(`lens model ${report.lensmodel}`);
  if (report.residuals)
    lines.push(`RMS reprojection error ${fixed(report.residuals.rms_px, 3)} px over ${views.used ?? '?'} ` +
      `of ${views.total ?? '?'} views; worst ${fixed(report.residuals.worst_px, 2)} px`);
  const fov = report.fov_deg;
  const fovSigma = sigma.fov_deg || {};
  if (fov && fov.horizontal !== null && fov.horizontal !== undefined)
    lines.push(`field of view ${pm(fov.horizontal, fovSigma.horizontal, 2)} x ` +
      `${pm(fov.vertical, fovSigma.vertical, 2)} deg (1 sigma)`);
  else lines.push({ text: 'field of view undefined (see the warnings)', warn: true });
  if (report.fx_px !== undefined)
    lines.push(`focal length ${pm(report.fx_px, sigma.fx_px, 2)} x ${pm(report.fy_px, sigma.fy_px, 2)} px, ` +
      `centre ${pm(report.cx_px, sigma.cx_px, 2)}, ${pm(report.cy_px, sigma.cy_px, 2)} px` +
      (report.focal_mm ? `; ${pm(report.focal_mm, sigma.focal_mm, 3)} mm` : ''));
  const u = report.projection_uncertainty || {};
  const worst = Math.max(...(u.points || []).map((p) => Number(p.at_infinity_px)).filter(Number.isFinite));
  if (Number.isFinite(worst))
    lines.push(`projection uncertainty at infinity: up to ${fixed(worst, 3)} px over the imager (1 sigma)`);
  return lines;
}

// The lines for a finished job.
export function resultLines(job) {
  const r = job.result || {};
  const report = r.report || {};
  const lines = [];
  if (job.kind === 'capture') lines.push(...captureLines(r));
  if (job.kind === 'analysis' && r.report) {
    if (report.summary && report.summary.text)
      lines.push(...report.summary.text.split('\n').filter((l) => l));
    const kind = report.kind || (report.summary || {}).kind || (job.request || {}).analysis;
    const perKind = { exposure: exposureLines, defocus: defocusLines, focus: focusLines,
      sfr: sfrLines, lensmap: lensMapLines }[kind];
    if (perKind) lines.push(...perKind(report));
  }
  if (job.kind === 'calibration' && r.report) lines.push(...calibrationLines(report));
  for (const w of report.warnings || [])
    lines.push({ text: `warning: ${typeof w === 'string' ? w : `${w.code}: ${w.message}`}`, warn: true });
  if (job.error) lines.push({ text: `${job.error.code}: ${job.error.message}`, warn: true });
  return lines.map((l) => (typeof l === 'string' ? { text: l } : l));
}
