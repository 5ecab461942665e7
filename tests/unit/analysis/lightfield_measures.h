// Measures the light-field tests and lightfield_bench share: an edge-profile difference
// between two images of one slanted edge, and depth error against a truth map.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace camlab::analysis::testing {

// A slanted edge's segment and its light side in an image (a frame truth's
// targets[].edge_px).
struct EdgeSegment {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // start, end (px)
  double nx = 0, ny = 0;                  // unit normal towards the light side
};

inline EdgeSegment edge_segment(const nlohmann::json& truth, const std::string& name) {
  for (const auto& t : truth.at("targets"))
    if (t.at("name") == name) {
      const auto& e = t.at("edge_px");
      EdgeSegment s{e["start"][0], e["start"][1], e["end"][0], e["end"][1], 0, 0};
      const double dx = s.x1 - s.x0, dy = s.y1 - s.y0, len = std::hypot(dx, dy);
      s.nx = -dy / len;
      s.ny = dx / len;
      const double lx = e["light_side_point"][0].get<double>() - e["middle"][0].get<double>();
      const double ly = e["light_side_point"][1].get<double>() - e["middle"][1].get<double>();
      if (lx * s.nx + ly * s.ny < 0) s.nx = -s.nx, s.ny = -s.ny;
      return s;
    }
  return {};
}

// The difference of two images (same size, CV_32F, the same units) across an edge: RMS
// over the pixels within `band_px` of the edge line along the middle 60% of its segment,
// over the edge's contrast in `reference` (the means beyond the band on its two sides,
// band_px + 2 to band_px + 6 px out). The band is where an edge blurred by up to
// 2 band_px - 6 px changes; outside it both images are flat.
struct EdgeProfileDifference {
  double rms_over_contrast = 0;
  double max_over_contrast = 0;
  double contrast = 0;
  int pixels = 0;
};

inline EdgeProfileDifference edge_profile_difference(const cv::Mat& image, const cv::Mat& reference,
                                                     const EdgeSegment& e, double band_px) {
  const double dx = e.x1 - e.x0, dy = e.y1 - e.y0, len = std::hypot(dx, dy);
  double dark = 0, light = 0, sq = 0, worst = 0;
  int n_dark = 0, n_light = 0, n = 0;
  std::vector<double> diffs;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      const double along = ((x - e.x0) * dx + (y - e.y0) * dy) / len;
      if (along < 0.2 * len || along > 0.8 * len) continue;
      const double across = (x - e.x0) * e.nx + (y - e.y0) * e.ny;
      const double r = reference.at<float>(y, x);
      if (std::fabs(across) <= band_px) {
        diffs.push_back(image.at<float>(y, x) - r);
      } else if (std::fabs(across) >= band_px + 2 && std::fabs(across) <= band_px + 6) {
        (across > 0 ? light : dark) += r;
        ++(across > 0 ? n_light : n_dark);
      }
    }
  EdgeProfileDifference out;
  if (n_dark == 0 || n_light == 0 || diffs.empty()) return out;
  out.contrast = light / n_light - dark / n_dark;
  for (double d : diffs) {
    sq += d * d;
    worst = std::max(worst, std::fabs(d));
    ++n;
  }
  out.pixels = n;
  out.rms_over_contrast = std::sqrt(sq / n) / std::fabs(out.contrast);
  out.max_over_contrast = worst / std::fabs(out.contrast);
  return out;
}

}  // namespace camlab::analysis::testing
