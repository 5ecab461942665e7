// Minimal x-y plots as PNG (OpenCV drawing), for analysis reports: measured points with
// error bars and fitted curves on linear or log axes. Not a plotting library: one panel,
// auto-scaled axes with 5 ticks, one title.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "base/result.h"

namespace camlab::analysis {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  std::vector<double> y_error;  // empty, or 1-sigma per point (drawn as bars)
  bool line = false;            // true: a polyline (a fitted curve); false: markers
  int color_bgr = 0x0000c0;     // 0xBBGGRR
};

struct PlotSpec {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<PlotSeries> series;
};

// Writes a 640x420 PNG. Non-finite points (and non-positive ones on a log axis) are
// skipped. Errors: "empty_plot" (no drawable point), "io_error".
Status write_plot(const std::filesystem::path& png_path, const PlotSpec& spec);

}  // namespace camlab::analysis
