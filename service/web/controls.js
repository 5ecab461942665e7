// The camera's controls with their ranges and units: a slider and a number for integers, a
// checkbox for booleans, a list for menus. A change is sent at once (PUT
// /v1/cameras/{id}/controls), and what the driver applied is read back and shown beside it,
// since drivers clamp and round (and camlabd refuses a value outside the range, naming it).

import { api, enc } from './api.js';

// A control's value in physical units where camlab knows the unit.
function physical(control, value) {
  if (control.unit === '100 us') {
    const ms = value / 10;
    return ms >= 1 ? `${ms.toFixed(1)} ms` : `${(ms * 1000).toFixed(0)} µs`;
  }
  return '';
}

function cell(row, text, className) {
  const td = row.insertCell();
  if (text !== undefined) td.textContent = text;
  if (className) td.className = className;
  return td;
}

export class ControlsPanel {
  constructor(table, note, errorLine, onChanged) {
    this.table = table;
    this.note = note;
    this.errorLine = errorLine;
    this.onChanged = onChanged;  // called after a change, to read the camera back
    this.readBack = new Map();   // control name -> the last "applied" text
  }

  render(camera) {
    const busy = camera.running_job !== null && camera.running_job !== undefined;
    this.note.textContent = !camera.available
      ? `Camera unavailable: ${camera.unavailable_reason || 'unknown reason'}`
      : busy ? `Camera busy with job ${camera.running_job}: controls change when it is idle`
        : camera.measuring_latency ? 'Measuring the control latency (once per camera)...' : '';
    const focused = document.activeElement && document.activeElement.dataset.control;
    if (focused) return;  // do not redraw under the user's hands
    this.table.replaceChildren();
    for (const c of camera.controls || []) {
      if (c.type === 'button' || c.type === 'other') continue;
      const row = this.table.insertRow();
      row.dataset.control = c.name;
      const label = cell(row, c.label);
      label.title = c.name;
      const input = cell(row);
      const disabled = busy || c.read_only || c.inactive || !camera.available;
      if (c.type === 'boolean') {
        const box = document.createElement('input');
        box.type = 'checkbox';
        box.checked = c.current !== 0;
        box.dataset.control = c.name;
        box.disabled = disabled;
        box.addEventListener('change', () => this.set(camera.id, c, box.checked ? 1 : 0));
        input.append(box);
      } else if (c.menu) {
        const select = document.createElement('select');
        select.dataset.control = c.name;
        for (const item of c.menu) {
          const option = new Option(`${item.name} (${item.value})`, item.value);
          option.selected = item.value === c.current;
          select.add(option);
        }
        select.disabled = disabled;
        select.addEventListener('change', () => this.set(camera.id, c, Number(select.value)));
        input.append(select);
      } else {
        const slider = document.createElement('input');
        slider.type = 'range';
        const number = document.createElement('input');
        number.type = 'number';
        for (const el of [slider, number]) {
          el.min = c.min;
          el.max = c.max;
          el.step = c.step || 1;
          el.value = c.current;
          el.disabled = disabled;
        }
        number.dataset.control = c.name;
        slider.addEventListener('input', () => { number.value = slider.value; });
        slider.addEventListener('change', () => this.set(camera.id, c, Number(slider.value)));
        number.addEventListener('change', () => this.set(camera.id, c, Number(number.value)));
        input.append(slider, number);
      }
      const unit = physical(c, c.current);
      cell(row, `${c.unit || ''}${unit ? ` = ${unit}` : ''}`, 'muted');
      cell(row, c.menu || c.type === 'boolean' ? '' : `${c.min}..${c.max}${c.step > 1 ? ` step ${c.step}` : ''}`,
        'muted');
      const applied = cell(row, this.readBack.get(c.name) || '', 'applied');
      applied.dataset.appliedFor = c.name;
      if (c.inactive) cell(row, 'inactive (an auto mode is on)', 'muted');
    }
  }

  async set(cameraId, control, value) {
    this.errorLine.textContent = '';
    try {
      const answer = await api(`/v1/cameras/${enc(cameraId)}/controls`, {
        method: 'PUT', body: { [control.name]: value },
      });
      const { requested, applied } = answer.controls[control.name];
      const unit = physical(control, applied);
      this.readBack.set(control.name, `applied ${applied}${unit ? ` (${unit})` : ''}` +
        (applied !== requested ? `, not ${requested}: the driver adjusted it` : ''));
    } catch (error) {
      this.errorLine.textContent = `${control.name}: ${error.message}`;
    }
    if (document.activeElement) document.activeElement.blur();
    await this.onChanged();
  }
}
