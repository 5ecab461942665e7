// Calibration plots through analysis::write_plot (plot.h).
#include "calib/plots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <system_error>

#include "analysis/plot.h"
#include "base/format.h"
#include "calib/lens_model.h"
#include "calib/uncertainty.h"

namespace camlab::calib {
namespace {

namespace fs = std::filesystem;
using analysis::PlotHeatmap;
using analysis::PlotSeries;
using analysis::PlotSpec;

constexpr int kRed = 0x0000d0, kBlue = 0xc04000, kGreen = 0x008000;

// The imager as an image-coordinate panel: pixel centres 0..W-1, y down, equal aspect.
PlotSpec imager_panel(const CalibrationData& data, const std::string& title) {
  PlotSpec spec;
  spec.title = title;
  spec.x_label = "x (px)";
  spec.y_label = "y (px)";
  spec.x_range = {{-0.5, data.imager_width_px - 0.5}};
  spec.y_range = {{-0.5, data.imager_height_px - 0.5}};
  spec.y_down = true;
  spec.equal_aspect = true;
  spec.width_px = 900;
  spec.height_px = 640;
  return spec;
}

// 1, 2 or 5 x 10^k nearest above v.
double nice(double v) {
  const double e = std::pow(10.0, std::floor(std::log10(v)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * e >= v) return m * e;
  return 10 * e;
}

double percentile(std::vector<double> v, double p) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::nan("");
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// The residuals binned over the imager, as one reads a calibration: each cell's mean
// residual as an arrow (a pattern of arrows is a model that does not fit: distortion left
// unmodelled, a warped board) over the cell's RMS residual in colour; outliers marked.
// 5,000 raw vectors drawn one by one hide exactly that.
Status residual_vectors(const fs::path& path, const CalibrationData& data, const Solution& s) {
  constexpr int kCellsAcross = 24;
  constexpr int kMinPerCell = 3;
  const double cell_px = std::max(1.0, data.imager_width_px / double(kCellsAcross));
  const int cols = std::max(1, static_cast<int>(std::ceil(data.imager_width_px / cell_px)));
  const int rows = std::max(1, static_cast<int>(std::ceil(data.imager_height_px / cell_px)));
  std::vector<double> sum_dx(cols * rows, 0), sum_dy(cols * rows, 0), sum_sq(cols * rows, 0);
  std::vector<int> count(cols * rows, 0);
  PlotSeries out{"outliers", {}, {}, {}, false, kRed};
  for (const auto& r : s.residuals) {
    const auto& c = data.views[r.view].corners[r.corner];
    if (r.outlier) {
      out.x.push_back(c.x_px);
      out.y.push_back(c.y_px);
      continue;
    }
    const int i = std::clamp(static_cast<int>(c.x_px / cell_px), 0, cols - 1);
    const int j = std::clamp(static_cast<int>(c.y_px / cell_px), 0, rows - 1);
    const int k = j * cols + i;
    sum_dx[k] += r.dx_px;
    sum_dy[k] += r.dy_px;
    sum_sq[k] += r.dx_px * r.dx_px + r.dy_px * r.dy_px;
    ++count[k];
  }
  std::vector<double> rms(cols * rows, std::nan("")), mean_length;
  PlotSeries arrows{"", {}, {}, {}, false, 0x000000};
  std::vector<double> mean_dx, mean_dy;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const int k = j * cols + i;
      if (count[k] < kMinPerCell) continue;
      rms[k] = std::sqrt(sum_sq[k] / count[k]);
      arrows.x.push_back((i + 0.5) * cell_px);
      arrows.y.push_back((j + 0.5) * cell_px);
      mean_dx.push_back(sum_dx[k] / count[k]);
      mean_dy.push_back(sum_dy[k] / count[k]);
      mean_length.push_back(std::hypot(mean_dx.back(), mean_dy.back()));
    }
  // A 95th-percentile cell mean draws 0.8 of a cell long.
  const double p95 = percentile(mean_length, 0.95);
  const double scale = std::isfinite(p95) && p95 > 0 ? nice(0.8 * cell_px / p95) : 1.0;
  for (size_t k = 0; k < mean_dx.size(); ++k) {
    arrows.dx.push_back(scale * mean_dx[k]);
    arrows.dy.push_back(scale * mean_dy[k]);
  }
  arrows.label = "mean residual of a cell x " + format_printf("%g", scale);
  PlotSpec spec = imager_panel(
      data, format_printf("residuals (predicted - observed) in %.0f px cells of >= %d corners",
                          cell_px, kMinPerCell));
  spec.heatmap = PlotHeatmap{
      cols,         rows, rms, 0, cols * cell_px, 0, rows * cell_px, "RMS residual (px)",
      std::nullopt, false};
  out.marker_px = 3;
  spec.series = {arrows, out};
  return analysis::write_plot(path, spec);
}

// Each view's RMS residual: a view far above the rest is a bad detection or a moved board.
Status residuals_per_view(const fs::path& path, const CalibrationData& data, const Solution& s) {
  std::vector<double> sum_sq(data.views.size(), 0);
  std::vector<int> count(data.views.size(), 0), outliers(data.views.size(), 0);
  for (const auto& r : s.residuals) {
    if (r.view < 0 || static_cast<size_t>(r.view) >= data.views.size()) continue;
    if (r.outlier) {
      ++outliers[r.view];
      continue;
    }
    sum_sq[r.view] += r.dx_px * r.dx_px + r.dy_px * r.dy_px;
    ++count[r.view];
  }
  PlotSpec spec;
  spec.title = format_printf("RMS residual per view (all views: %.3f px)", s.rms_px);
  spec.x_label = "view";
  spec.y_label = "RMS residual (px)";
  PlotSeries bars{"inliers", {}, {}, {}, false, kBlue};
  bars.bar_width = 0.8;
  PlotSeries with_outliers{"views with outliers", {}, {}, {}, false, kRed};
  for (size_t v = 0; v < data.views.size(); ++v) {
    if (count[v] == 0) continue;
    const double value = std::sqrt(sum_sq[v] / count[v]);
    bars.x.push_back(static_cast<double>(v));
    bars.y.push_back(value);
    if (outliers[v] > 0) {
      with_outliers.x.push_back(static_cast<double>(v));
      with_outliers.y.push_back(value);
    }
  }
  spec.series = {bars, with_outliers};
  spec.y_range = {{0, 1.15 * percentile(bars.y, 1.0)}};
  return analysis::write_plot(path, spec);
}

Status residual_histogram(const fs::path& path, const Solution& s, double sigma_px) {
  std::vector<double> comp;
  for (const auto& r : s.residuals)
    if (!r.outlier) {
      comp.push_back(r.dx_px);
      comp.push_back(r.dy_px);
    }
  if (comp.empty()) return make_error("empty_plot", "no inlier residuals");
  if (!(sigma_px > 0)) sigma_px = s.rms_px / std::sqrt(2.0);
  const double half = 4.0 * std::max(sigma_px, 1e-6);
  constexpr int kBins = 41;
  const double bin = 2 * half / kBins;
  std::vector<double> counts(kBins, 0.0);
  int beyond = 0;
  for (double v : comp) {
    const int b = static_cast<int>(std::floor((v + half) / bin));
    if (b < 0 || b >= kBins)
      ++beyond;
    else
      counts[b] += 1;
  }
  PlotSpec spec;
  spec.title =
      "inlier residuals, x and y components (" + std::to_string(beyond) + " beyond 4 sigma)";
  spec.x_label = "residual (px)";
  spec.y_label = "corners per bin";
  PlotSeries bars{"observed", {}, {}, {}, false, kBlue};
  bars.bar_width = 0.9 * bin;
  PlotSeries normal{
      "normal, sigma " + format_printf("%.3f", sigma_px) + " px", {}, {}, {}, true, kRed};
  for (int b = 0; b < kBins; ++b) {
    bars.x.push_back(-half + (b + 0.5) * bin);
    bars.y.push_back(counts[b]);
  }
  for (int k = 0; k <= 200; ++k) {
    const double x = -half + k * 2 * half / 200;
    normal.x.push_back(x);
    normal.y.push_back(comp.size() * bin * std::exp(-0.5 * x * x / (sigma_px * sigma_px)) /
                       (sigma_px * std::sqrt(2 * M_PI)));
  }
  spec.series = {bars, normal};
  return analysis::write_plot(path, spec);
}

Status coverage(const fs::path& path, const CalibrationData& data, const CalibrationReport& r) {
  PlotSpec spec = imager_panel(
      data, "observed corners: " + format_printf("%.0f", 100 * r.coverage) + "% of the imager, " +
                format_printf("%.0f", 100 * r.edge_coverage) + "% of its border");
  PlotSeries in{"inliers", {}, {}, {}, false, kBlue}, out{"outliers", {}, {}, {}, false, kRed};
  in.marker_px = 1;
  out.marker_px = 2;
  for (const auto& res : r.solution.residuals) {
    const auto& c = data.views[res.view].corners[res.corner];
    (res.outlier ? out : in).x.push_back(c.x_px);
    (res.outlier ? out : in).y.push_back(c.y_px);
  }
  spec.series = {in, out};
  return analysis::write_plot(path, spec);
}

// A field over the imager on a grid of nodes at pixel centres 0..W-1, 0..H-1.
PlotHeatmap imager_heatmap(const CalibrationData& data, int cols, int rows,
                           std::vector<double> values, const std::string& label) {
  PlotHeatmap h;
  h.cols = cols;
  h.rows = rows;
  h.values = std::move(values);
  h.x0 = 0;
  h.x1 = data.imager_width_px - 1;
  h.y0 = 0;
  h.y1 = data.imager_height_px - 1;
  h.label = label;
  return h;
}

Status uncertainty_map(const fs::path& path, const CalibrationData& data, const Solution& s) {
  constexpr int kCols = 48, kRows = 30;
  std::vector<double> grid;
  CAMLAB_ASSIGN(grid, uncertainty_grid(s, kCols, kRows, std::numeric_limits<double>::infinity()));
  PlotSpec spec =
      imager_panel(data, "projection uncertainty at infinity (worst-direction 1 sigma, px)");
  spec.heatmap = imager_heatmap(data, kCols, kRows, grid, "px");
  // Extrapolated corners can be orders of magnitude above the centre: a log scale, capped
  // at 100x the least value.
  spec.heatmap->log_scale = true;
  const double lo = percentile(grid, 0.0), hi = percentile(grid, 1.0);
  if (std::isfinite(lo) && lo > 0 && hi > lo) spec.heatmap->range = {{lo, std::min(hi, 100 * lo)}};
  return analysis::write_plot(path, spec);
}

Status distortion_map(const fs::path& path, const CalibrationData& data, const Solution& s) {
  constexpr int kCols = 48, kRows = 30;
  std::vector<double> q;
  for (int r = 0; r < kRows; ++r)
    for (int k = 0; k < kCols; ++k) {
      q.push_back(k * (data.imager_width_px - 1.0) / (kCols - 1));
      q.push_back(r * (data.imager_height_px - 1.0) / (kRows - 1));
    }
  std::vector<char> valid;
  std::vector<double> v;
  CAMLAB_ASSIGN(v, unproject_each(s.model, q, &valid));
  const auto& in = s.model.intrinsics;
  std::vector<double> magnitude(kCols * kRows, std::nan(""));
  for (int i = 0; i < kCols * kRows; ++i) {
    if (!valid[i] || !(v[3 * i + 2] > 1e-6)) continue;  // behind the pinhole's plane
    const double xp = in[0] * v[3 * i] / v[3 * i + 2] + in[2],
                 yp = in[1] * v[3 * i + 1] / v[3 * i + 2] + in[3];
    magnitude[i] = std::hypot(q[2 * i] - xp, q[2 * i + 1] - yp);
  }
  PlotSpec spec =
      imager_panel(data, "distortion: shift from the pinhole core, px (" + s.model.lensmodel + ")");
  spec.heatmap = imager_heatmap(data, kCols, kRows, magnitude, "px");
  return analysis::write_plot(path, spec);
}

}  // namespace

Result<PlotFiles> write_calibration_plots(const fs::path& dir, const CalibrationData& data,
                                          const CalibrationReport& report) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error("io_error", "cannot create '" + dir.string() + "': " + ec.message());
  const Solution& s = report.solution;
  const double sigma = report.uncertainty ? report.uncertainty->observed_sigma_px : 0.0;
  PlotFiles files;
  auto run = [&](const char* name, const Status& status) -> Status {
    if (status) {
      files.written.push_back(dir / name);
      return {};
    }
    if (status.error().code == "io_error") return status;
    files.skipped.push_back(std::string(name) + ": " + status.error().message);
    return {};
  };
  const std::pair<const char*, Status> plots[] = {
      {"residuals.png", residual_vectors(dir / "residuals.png", data, s)},
      {"residuals_per_view.png", residuals_per_view(dir / "residuals_per_view.png", data, s)},
      {"residual_histogram.png", residual_histogram(dir / "residual_histogram.png", s, sigma)},
      {"coverage.png", coverage(dir / "coverage.png", data, report)},
      {"uncertainty.png", uncertainty_map(dir / "uncertainty.png", data, s)},
      {"distortion.png", distortion_map(dir / "distortion.png", data, s)}};
  for (const auto& [name, status] : plots) {
    if (Status st = run(name, status); !st) return st.error();
  }
  return files;
}

}  // namespace camlab::calib
