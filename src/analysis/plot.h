// Plots for analysis and calibration reports: measured points with error bars, fitted
// curves, vectors (residuals over an imager), histogram bars, and a heat map with a colour
// bar (uncertainty or distortion over an imager), on linear or log axes. A PlotSpec says
// what to draw; gnuplot draws it (round ticks, legends beside the data, viridis colour
// bars), from a script written beside the PNG.
//
// Reentrant (each plot runs its own gnuplot process).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"

namespace camlab::analysis {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  std::vector<double> y_error;  // empty, or 1-sigma per point (drawn as bars)
  bool line = false;            // true: a polyline (a fitted curve); false: markers
  int color_bgr = 0x0000c0;     // 0xBBGGRR
  // Vectors: when non-empty (one per point), a segment from (x, y) to (x + dx, y + dy)
  // in data units is drawn instead of a marker (scale them before: e.g. residuals x 100).
  std::vector<double> dx, dy;
  double bar_width = 0;  // > 0: bars from y = 0 to y, this wide in x (histograms)
  int marker_px = 3;     // marker radius
};

// A scalar field on a regular grid drawn under the series: value (row-major, cols x
// rows, NaN = no value) at the grid's cell centres spanning [x0, x1] x [y0, y1], coloured
// by the viridis map over [min, max] of the finite values (or the given range), with a
// colour bar labelled `label`.
struct PlotHeatmap {
  int cols = 0, rows = 0;
  std::vector<double> values;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  std::string label;
  std::optional<std::pair<double, double>> range;  // colours span it; values beyond saturate
  bool log_scale = false;  // colours by log10(value) (values <= 0 show no colour)
};

struct PlotSpec {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<PlotSeries> series;
  std::optional<PlotHeatmap> heatmap;
  // Fixed axis ranges (data units); empty: fitted to the data with a margin.
  std::optional<std::pair<double, double>> x_range, y_range;
  bool y_down = false;        // image coordinates: y grows downwards
  bool equal_aspect = false;  // one data unit is as long on both axes (images): the plot
                              // area shrinks to the data's aspect within width x height
  int width_px = 640, height_px = 420;
};

// Writes the PNG and, beside it, the gnuplot script that drew it (png_path with ".gp")
// and the chart's data (".json", to_json below).
// Non-finite points (and non-positive ones on a log axis) are skipped. Errors:
// "empty_plot" (no drawable point and no heat map), "io_error", "plotter_failed" (gnuplot
// missing, or it refused the script: its message).
Status write_plot(const std::filesystem::path& png_path, const PlotSpec& spec);

// What the plot shows, as data, for pages that draw it themselves (the dashboard's
// interactive charts): {title, x_label, y_label, log_x, log_y, y_down, x_range, y_range,
// series: [{label, line, colour: "#rrggbb", x, y, y_error?, dx?, dy?, bar_width?}],
// heatmap?: {cols, rows, x0, x1, y0, y1, label, log_scale, range?, values}}; non-finite
// numbers become null. write_plot() writes it beside the PNG (png_path with ".json").
nlohmann::json to_json(const PlotSpec& spec);

// The script write_plot() runs, with the data inline; `points` gets the number of
// drawable points of all series.
std::string gnuplot_script(const std::filesystem::path& png_path, const PlotSpec& spec,
                           int* points);

}  // namespace camlab::analysis
