// The capture form: single frames, exposure brackets, focus stacks, aperture series and lens
// maps (f-stops x focus positions), as POST /v1/cameras/{id}/captures takes them
// (docs/capture-api.md). camlabd checks every value against the camera's ranges and says
// what is allowed; the page only parses lists.

import { api, enc } from './api.js';

function numbers(text, what) {
  const values = text.split(/[\s,;]+/).filter((s) => s.length).map(Number);
  if (!values.length || values.some((v) => !Number.isFinite(v)))
    throw new Error(`${what}: give numbers separated by commas`);
  return values;
}

export function captureRequest(form) {
  const kind = form.querySelector('#capture-kind').value;
  const repeats = Number(form.querySelector('#capture-repeats').value);
  const request = { kind, repeats };
  const label = form.querySelector('#capture-label').value.trim();
  if (label) request.label = label;
  const format = form.querySelector('#capture-format').value;
  if (format) request.format = JSON.parse(format);
  if (kind === 'bracket') {
    request.exposures_us = numbers(form.querySelector('#bracket-exposures').value, 'Exposures');
  } else if (kind === 'focus_stack') {
    request.start = Number(form.querySelector('#focus-start').value);
    request.stop = Number(form.querySelector('#focus-stop').value);
    request.step = Number(form.querySelector('#focus-step').value);
  } else if (kind === 'aperture_series') {
    request.f_numbers = numbers(form.querySelector('#aperture-f-numbers').value, 'f-numbers');
    // Optional: held across the stops for blur measurements; one time for the 1/N^2 law.
    const base = form.querySelector('#aperture-base-exposure').value.trim();
    if (base) request.base_exposure_us = Number(base);
  } else if (kind === 'lens_map') {
    request.f_numbers = numbers(form.querySelector('#lens-map-f-numbers').value, 'f-numbers');
    request.start = Number(form.querySelector('#lens-map-start').value);
    request.stop = Number(form.querySelector('#lens-map-stop').value);
    request.step = Number(form.querySelector('#lens-map-step').value);
    // Held across the stops (time x N^2), or every stop would be exposed differently.
    const base = form.querySelector('#lens-map-base-exposure').value.trim();
    if (base) request.base_exposure_us = Number(base);
  }
  return request;
}

// The camera's formats, sizes and frame rates (GET /v1/cameras/{id}) to choose from; the
// first choice leaves it to camlabd (the format keeping the most signal, the largest
// size). Rebuilt only when the list changes, so a choice survives the periodic refresh.
export function showFormats(form, formats) {
  const select = form.querySelector('#capture-format');
  const key = JSON.stringify(formats || []);
  if (select.dataset.key === key) return;
  select.dataset.key = key;
  const chosen = select.value;
  const options = [new Option("camlabd's choice: most signal, largest size", '')];
  for (const f of formats || [])
    for (const size of f.sizes || [])
      for (const interval of size.intervals.length ? size.intervals : [null]) {
        const value = { fourcc: f.fourcc, width: size.width_px, height: size.height_px };
        let text = `${f.fourcc.trim()} ${size.width_px} x ${size.height_px}`;
        if (interval && interval.frame_interval_s > 0) {
          value.frame_interval_us = Math.round(interval.frame_interval_s * 1e6);
          text += ` @ ${Number(interval.frames_per_second.toFixed(2))} frames/s`;
        }
        text += f.description ? ` (${f.description})` : '';
        options.push(new Option(text, JSON.stringify(value)));
      }
  select.replaceChildren(...options);
  if ([...select.options].some((o) => o.value === chosen)) select.value = chosen;
}

// Wires the form; `cameraId()` gives the selected camera, `onQueued(job)` is told of the job.
export function setUpCaptureForm(form, errorLine, cameraId, onQueued) {
  const kind = form.querySelector('#capture-kind');
  const showFields = () => {
    for (const fields of form.querySelectorAll('.kind-fields'))
      fields.hidden = fields.dataset.kind !== kind.value;
  };
  kind.addEventListener('change', showFields);
  showFields();
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    errorLine.textContent = '';
    const button = form.querySelector('#capture-start');
    button.disabled = true;
    try {
      const job = await api(`/v1/cameras/${enc(cameraId())}/captures`, {
        method: 'POST', body: captureRequest(form),
      });
      onQueued(job);
    } catch (error) {
      errorLine.textContent = error.message;
    } finally {
      button.disabled = false;
    }
  });
}
