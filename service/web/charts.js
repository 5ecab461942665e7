// Interactive charts in the dashboard, drawn with uPlot (vendored: uplot-1.6.32.iife.min.js,
// MIT, from npm; docs/dashboard.md says why uPlot) from the data each plot's PNG was drawn
// from (analysis/plot.h: GET .../files/plots/NAME.json). Hovering reads every series' value;
// dragging zooms, a double click resets. Charts of points and lines are drawn here; heat
// maps, vector fields, bar charts and image panels keep gnuplot's PNG, which is always a
// click away.

/* global uPlot */

const SIZE = { width: 640, height: 380 };

// One chart of points and lines, or null when the data is of another kind.
export function drawChart(container, chart) {
  // Image panels (y down, one pixel as long on both axes) stay gnuplot's, drawn as the
  // imager is.
  if (typeof uPlot === 'undefined' || chart.heatmap || chart.y_down ||
    chart.series.some((s) => s.dx || s.bar_width) || !chart.series.length) return null;
  // uPlot's series share one x array: the union of every series' x, each series null where
  // it has no point (lines span those gaps).
  const xs = [...new Set(chart.series.flatMap((s) => s.x.filter((v) => v !== null)))].sort((a, b) => a - b);
  const index = new Map(xs.map((x, i) => [x, i]));
  const columns = chart.series.map((s) => {
    const column = new Array(xs.length).fill(null);
    s.x.forEach((x, i) => { if (x !== null && s.y[i] !== null) column[index.get(x)] = s.y[i]; });
    return column;
  });
  const errors = chart.series.map((s) => {
    if (!s.y_error) return null;
    const column = new Array(xs.length).fill(null);
    s.x.forEach((x, i) => { if (x !== null) column[index.get(x)] = s.y_error[i]; });
    return column;
  });
  const positive = (v) => v !== null && v > 0;
  if ((chart.log_x && !xs.every(positive))) return null;
  const opts = {
    title: chart.title,
    ...SIZE,
    scales: {
      x: { time: false, distr: chart.log_x ? 3 : 1, ...(chart.x_range ? { range: chart.x_range } : {}) },
      y: { distr: chart.log_y ? 3 : 1, ...(chart.y_range ? { range: chart.y_range } : {}) },
    },
    axes: [{ label: chart.x_label, stroke: '#ccc', grid: { stroke: '#2c333b' } },
      { label: chart.y_label, stroke: '#ccc', grid: { stroke: '#2c333b' }, size: 60 }],
    series: [{ label: chart.x_label }, ...chart.series.map((s, k) => ({
      label: seriesLabel(chart.series, k),
      stroke: s.colour,
      width: s.line ? 2 : 0,
      spanGaps: true,
      paths: s.line ? undefined : () => null,
      points: { show: !s.line, size: 6, fill: s.colour, stroke: s.colour },
    }))],
    // 1-sigma bars where the data has them, as the PNG draws them.
    hooks: { draw: [(u) => drawErrorBars(u, errors, chart.series)] },
    legend: { live: true },
  };
  const plot = new uPlot(opts, [xs, ...columns], container);
  container.dataset.series = String(chart.series.length);
  container.dataset.points = String(columns.reduce((n, c) => n + c.filter((v) => v !== null).length, 0));
  return plot;
}

// A series the PNG leaves out of its key (the points under a fitted line of the same
// colour) is named after that line here, since the live legend lists every series.
function seriesLabel(series, k) {
  if (series[k].label) return series[k].label;
  const twin = [series[k + 1], series[k - 1]].find((s) => s && s.label && s.colour === series[k].colour);
  return twin ? `${twin.label.split(':')[0]}: measured` : `series ${k + 1}`;
}

function drawErrorBars(u, errors, series) {
  const ctx = u.ctx;
  ctx.save();
  ctx.lineWidth = 1;
  errors.forEach((column, k) => {
    if (!column || !u.series[k + 1].show) return;
    ctx.strokeStyle = series[k].colour;
    ctx.beginPath();
    const ys = u.data[k + 1];
    for (let i = 0; i < ys.length; i++) {
      if (ys[i] === null || column[i] === null || !(column[i] > 0)) continue;
      const x = u.valToPos(u.data[0][i], 'x', true);
      const top = u.valToPos(ys[i] + column[i], 'y', true);
      const bottom = u.valToPos(Math.max(ys[i] - column[i], u.scales.y.distr === 3 ? ys[i] / 10 : -Infinity), 'y', true);
      ctx.moveTo(x, top);
      ctx.lineTo(x, bottom);
    }
    ctx.stroke();
  });
  ctx.restore();
}
