#include "calib/residual_pattern.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace camlab::calib {

ResidualPattern residual_pattern(const CalibrationData& data, const Solution& s) {
  constexpr int kGx = 16, kGy = 10;
  ResidualPattern out;
  if (data.imager_width_px <= 0 || data.imager_height_px <= 0) return out;
  std::vector<double> sum_x(kGx * kGy, 0.0), sum_y(kGx * kGy, 0.0);
  std::vector<int> count(kGx * kGy, 0);
  double sum_sq = 0;
  for (const auto& r : s.residuals) {
    if (r.outlier || r.view < 0 || r.view >= static_cast<int>(data.views.size())) continue;
    const auto& corners = data.views[r.view].corners;
    if (r.corner < 0 || r.corner >= static_cast<int>(corners.size())) continue;
    const auto& c = corners[r.corner];
    const double ex = c.weight * r.dx_px, ey = c.weight * r.dy_px;
    if (!std::isfinite(ex) || !std::isfinite(ey)) continue;
    const int gx = std::clamp(static_cast<int>(c.x_px / data.imager_width_px * kGx), 0, kGx - 1);
    const int gy = std::clamp(static_cast<int>(c.y_px / data.imager_height_px * kGy), 0, kGy - 1);
    sum_x[gy * kGx + gx] += ex;
    sum_y[gy * kGx + gx] += ey;
    ++count[gy * kGx + gx];
    sum_sq += ex * ex + ey * ey;
    ++out.residuals;
  }
  if (out.residuals < 20 || !(sum_sq > 0)) return out;
  const double sigma2 = sum_sq / (2.0 * out.residuals);  // per coordinate
  double t = 0;
  for (int k = 0; k < kGx * kGy; ++k) {
    if (count[k] < 2) continue;
    const double mx = sum_x[k] / count[k], my = sum_y[k] / count[k];
    t += count[k] * (mx * mx + my * my) / sigma2;
    ++out.cells;
  }
  if (out.cells == 0) return out;
  out.z = (t - 2.0 * out.cells) / std::sqrt(4.0 * out.cells);
  // Neighbour correlation within views.
  const int cols = data.board.cols, rows = data.board.rows;
  std::map<std::pair<int, int>, std::pair<double, double>> by_corner;  // (view, corner)
  for (const auto& r : s.residuals) {
    if (r.outlier || r.view < 0 || r.view >= static_cast<int>(data.views.size())) continue;
    const auto& corners = data.views[r.view].corners;
    if (r.corner < 0 || r.corner >= static_cast<int>(corners.size())) continue;
    const double w = corners[r.corner].weight;
    by_corner[{r.view, r.corner}] = {w * r.dx_px, w * r.dy_px};
  }
  double sum_dot = 0, sum_dot2 = 0;
  for (const auto& [key, e] : by_corner) {
    const int i = key.second % cols, j = key.second / cols;
    for (const auto& [di, dj] : {std::pair{1, 0}, std::pair{0, 1}}) {
      if (i + di >= cols || j + dj >= rows) continue;
      const auto it = by_corner.find({key.first, key.second + dj * cols + di});
      if (it == by_corner.end()) continue;
      const double dot = e.first * it->second.first + e.second * it->second.second;
      sum_dot += dot;
      sum_dot2 += dot * dot;
    }
  }
  if (sum_dot2 > 0) out.neighbour_z = sum_dot / std::sqrt(sum_dot2);
  return out;
}

}  // namespace camlab::calib
