// Edge measurement: window choice, rejections, baseline removal, diffraction flag.
#include "analysis/defocus.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace camlab::analysis {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// The largest half-length (<= wanted) for which the window around (x, y) lies within the
// image's pixel centres, or 0 when even a zero-length window does not fit.
double fit_half_length_in_image(const cv::Mat& image, double x, double y, double angle,
                                double half_width, double wanted) {
  const double tx = std::cos(angle), ty = std::sin(angle);
  const double nx = -ty, ny = tx;
  double best = 0;
  // Each axis bounds hl linearly: |tx| hl + hw |nx| <= room.
  const double room_x = std::min(x, image.cols - 1 - x) - half_width * std::fabs(nx);
  const double room_y = std::min(y, image.rows - 1 - y) - half_width * std::fabs(ny);
  if (room_x < 0 || room_y < 0) return 0.0;
  best = wanted;
  if (std::fabs(tx) > 1e-12) best = std::min(best, room_x / std::fabs(tx));
  if (std::fabs(ty) > 1e-12) best = std::min(best, room_y / std::fabs(ty));
  return std::max(0.0, best - 1e-6);
}

// The synthetic edge for the baseline inversion: long enough for a stable noise-free fit,
// wide enough for the disk, the Gaussian and 8 px of flat level.
Result<double> fit_synthetic(double diameter_px, double sigma_px, double angle_rad) {
  const double half_width = 0.5 * diameter_px + 4.0 * sigma_px + 8.0;
  const double half_length = 24.0;
  const double extent = half_length + half_width + 4.0 * sigma_px + 4.0;
  const int size = 2 * static_cast<int>(std::ceil(extent)) + 1;
  const double centre = 0.5 * (size - 1) + 0.237;  // off the pixel grid's symmetry
  const EdgeLine line{centre, centre, angle_rad};
  const cv::Mat image = render_edge_model(size, size, line, diameter_px, sigma_px, 0.0, 1.0);
  EdgeFitOptions options;
  options.half_length_px = half_length;
  options.half_width_px = half_width;
  options.fit_angle = false;
  auto fit = fit_pillbox_edge(image, line, options);
  if (!fit) return fit.error();
  return fit->diameter_px;
}

}  // namespace

cv::Mat render_edge_model(int rows, int cols, const EdgeLine& line, double diameter_px,
                          double sigma_px, double dark, double light) {
  cv::Mat image(rows, cols, CV_32F);
  const double nx = -std::sin(line.angle_rad), ny = std::cos(line.angle_rad);
  for (int r = 0; r < rows; ++r) {
    auto* row = image.ptr<float>(r);
    for (int c = 0; c < cols; ++c) {
      const double d = (c - line.x_px) * nx + (r - line.y_px) * ny;
      row[c] = static_cast<float>(dark + (light - dark) *
                                             pillbox_esf_pixel(d, diameter_px, nx, ny));
    }
  }
  if (sigma_px > 0)
    cv::GaussianBlur(image, image, cv::Size(), sigma_px, sigma_px, cv::BORDER_REFLECT);
  return image;
}

Result<double> apparent_diameter_px(double diameter_px, double sigma_px, double angle_rad) {
  if (!(diameter_px >= 0) || !(sigma_px >= 0) || !std::isfinite(diameter_px) ||
      !std::isfinite(sigma_px) || !std::isfinite(angle_rad))
    return make_error("invalid_argument", "diameter and sigma must be finite and >= 0");
  if (sigma_px == 0) return diameter_px;
  return fit_synthetic(diameter_px, sigma_px, angle_rad);
}

Result<BaselineInversion> remove_baseline_blur(double apparent_px, double sigma_px,
                                               double angle_rad) {
  if (!std::isfinite(apparent_px) || !(apparent_px >= 0) || !std::isfinite(sigma_px) ||
      !(sigma_px >= 0) || !std::isfinite(angle_rad))
    return make_error("invalid_argument", "apparent diameter and sigma must be finite, >= 0");
  BaselineInversion inv;
  if (sigma_px == 0) {
    inv.diameter_px = apparent_px;
    return inv;
  }
  double f0;
  CAMLAB_ASSIGN(f0, apparent_diameter_px(0.0, sigma_px, angle_rad));
  inv.apparent_at_zero_px = f0;
  // Slope near 0 from a small step (D_app grows as D^2 there, so this is small).
  if (apparent_px <= f0) {
    inv.at_baseline = true;
    double f1;
    CAMLAB_ASSIGN(f1, apparent_diameter_px(0.5, sigma_px, angle_rad));
    inv.slope = std::max(1e-3, (f1 - f0) / 0.5);
    return inv;
  }
  // Bracket: D_app(D) >= D, so the root lies in [0, apparent]; D_app is increasing.
  double lo = 0, flo = f0 - apparent_px;
  double hi = apparent_px, fhi;
  CAMLAB_ASSIGN(fhi, apparent_diameter_px(hi, sigma_px, angle_rad));
  fhi -= apparent_px;
  if (fhi < 0) {  // should not happen; the disk alone already reads as `apparent`
    inv.diameter_px = apparent_px;
    return inv;
  }
  // Illinois (regula falsi that halves a stale end's value): robust and fast here.
  int side = 0;
  double x = hi;
  for (int it = 0; it < 40 && hi - lo > 1e-4; ++it) {
    x = (lo * fhi - hi * flo) / (fhi - flo);
    if (!(x > lo && x < hi)) x = 0.5 * (lo + hi);
    double fx;
    CAMLAB_ASSIGN(fx, apparent_diameter_px(x, sigma_px, angle_rad));
    fx -= apparent_px;
    if (fx == 0) {
      lo = hi = x;
      break;
    }
    if ((fx > 0) == (fhi > 0)) {
      hi = x;
      fhi = fx;
      if (side == 1) flo *= 0.5;
      side = 1;
    } else {
      lo = x;
      flo = fx;
      if (side == -1) fhi *= 0.5;
      side = -1;
    }
  }
  inv.diameter_px = 0.5 * (lo + hi);
  const double h = std::max(0.05, 0.02 * inv.diameter_px);
  double fa, fb;
  CAMLAB_ASSIGN(fa, apparent_diameter_px(std::max(0.0, inv.diameter_px - h), sigma_px, angle_rad));
  CAMLAB_ASSIGN(fb, apparent_diameter_px(inv.diameter_px + h, sigma_px, angle_rad));
  inv.slope = std::max(1e-3, (fb - fa) / (inv.diameter_px + h - std::max(0.0, inv.diameter_px - h)));
  return inv;
}

Result<EdgeMeasurement> measure_edge(const cv::Mat& image, const EdgeSegment& edge,
                                     std::span<const EdgeSegment> neighbours,
                                     const EdgeMeasureOptions& options) {
  if (image.empty() || image.channels() != 1)
    return make_error("invalid_argument", "edge '" + edge.name + "': empty or multi-channel image");
  const double dx = edge.end_x_px - edge.start_x_px, dy = edge.end_y_px - edge.start_y_px;
  const double length = std::hypot(dx, dy);
  if (!std::isfinite(length) || length < 8.0)
    return make_error("invalid_argument", "edge '" + edge.name + "' is shorter than 8 px or not finite");
  if (!(options.baseline_sigma_px >= 0) || !std::isfinite(options.baseline_sigma_px))
    return make_error("invalid_argument", "baseline_sigma_px must be finite and >= 0");

  EdgeMeasurement m;
  m.name = edge.name;
  const double angle = std::atan2(dy, dx);
  const double mid_x = edge.start_x_px + 0.5 * dx, mid_y = edge.start_y_px + 0.5 * dy;

  // The window across the edge is bounded by the target's extent, by the nearest
  // neighbouring edge that passes alongside the window (its part within the window's
  // length, +2 px), and by the image. A neighbour beyond the window's ends (e.g. a
  // target border across the edge) does not bound it.
  auto across_limit = [&](double half_length) {
    double limit = edge.max_half_width_px > 0 ? edge.max_half_width_px : kInf;
    const double ux = dx / length, uy = dy / length;  // along; across is (-uy, ux)
    const double reach = half_length + 2.0;
    for (const EdgeSegment& n : neighbours) {
      if (&n == &edge) continue;
      // Along/across coordinates of the neighbour's ends, relative to the edge's middle.
      const double a0 = (n.start_x_px - mid_x) * ux + (n.start_y_px - mid_y) * uy;
      const double c0 = -(n.start_x_px - mid_x) * uy + (n.start_y_px - mid_y) * ux;
      const double a1 = (n.end_x_px - mid_x) * ux + (n.end_y_px - mid_y) * uy;
      const double c1 = -(n.end_x_px - mid_x) * uy + (n.end_y_px - mid_y) * ux;
      // Clip the neighbour to |along| <= reach (it is a straight line in these coordinates).
      double t_lo = 0, t_hi = 1;
      if (std::fabs(a1 - a0) < 1e-12) {
        if (std::fabs(a0) > reach) continue;
      } else {
        double ta = (-reach - a0) / (a1 - a0), tb = (reach - a0) / (a1 - a0);
        if (ta > tb) std::swap(ta, tb);
        t_lo = std::max(t_lo, ta);
        t_hi = std::min(t_hi, tb);
        if (t_lo > t_hi) continue;
      }
      const double ca = c0 + t_lo * (c1 - c0), cb = c0 + t_hi * (c1 - c0);
      const double closest = (ca > 0) != (cb > 0) ? 0.0 : std::min(std::fabs(ca), std::fabs(cb));
      limit = std::min(limit, closest);
    }
    return limit;
  };

  // Passes: guess the blur, fit, and refit with a window sized for the blur found.
  double blur_guess = 4.0;
  bool have_fit = false;
  std::string last_error;
  for (int pass = 0; pass < 6; ++pass) {
    const double want_hw = 0.5 * blur_guess + 8.0;
    // Keep the window's ends D/2 + 3 px inside the segment's ends (the target's border
    // blurs inwards), allowing the border to lean 10 degrees from perpendicular.
    double hl = 0.5 * length - 0.5 * blur_guess - 3.0 - 0.18 * want_hw;
    const double limit_n = across_limit(std::max(hl, 1.0));
    const double limit_target = edge.max_half_width_px > 0 ? edge.max_half_width_px : kInf;
    // Flat level beyond the blur must not include the neighbour's own blur.
    double hw = std::min({want_hw, limit_target - 0.5 * blur_guess - 1.0,
                          0.5 * limit_n - 0.5});
    hl = fit_half_length_in_image(image, mid_x, mid_y, angle, std::max(hw, 1.0), hl);
    m.half_length_px = hl;
    m.half_width_px = hw;
    const bool neighbour_bound = 0.5 * limit_n - 0.5 < std::min(want_hw, limit_target - 0.5 * blur_guess - 1.0);
    if (hw < 0.5 * blur_guess + 2.5 || hl < 8.0) {
      m.status = neighbour_bound && hl >= 8.0 ? kEdgeNeighbourOverlap : kEdgeWindowTooSmall;
      m.message = "a window " + fmt(2 * hw) + " px wide and " + fmt(2 * hl) +
                  " px long cannot hold a blur of about " + fmt(blur_guess) +
                  " px plus flat level on both sides" +
                  (neighbour_bound ? " (a neighbouring edge is " + fmt(limit_n) + " px away)" : "");
      return m;
    }
    EdgeFitOptions fo;
    fo.half_length_px = hl;
    fo.half_width_px = hw;
    auto fit = fit_pillbox_edge(image, EdgeLine{mid_x, mid_y, angle}, fo);
    if (!fit) {
      last_error = fit.error().message;
      if (fit.error().code == kErrWindowTooSmall || fit.error().code == kErrNotConverged) {
        blur_guess = 2.0 * blur_guess + 4.0;  // the blur is wider than guessed
        continue;
      }
      m.status = kEdgeFitFailed;
      m.message = fit.error().code + ": " + fit.error().message;
      return m;
    }
    m.fit = *fit;
    have_fit = true;
    const double d = fit->diameter_px;
    if (hw >= 0.5 * d + 6.0 || hw < want_hw) {
      // Either the window is ample or it is already as wide as the bounds allow.
      if (hw < 0.5 * d + 2.5 + std::fabs(fit->offset_px)) {
        m.status = neighbour_bound ? kEdgeNeighbourOverlap : kEdgeWindowTooSmall;
        m.message = "the blur of " + fmt(d) + " px needs a window at least " +
                    fmt(d + 5.0) + " px wide; only " + fmt(2 * hw) + " px are free";
        return m;
      }
      break;
    }
    blur_guess = d;
    have_fit = false;
  }
  if (!have_fit) {
    m.status = kEdgeWindowTooSmall;
    m.message = "no window size held the blur (" + last_error + ")";
    return m;
  }

  // Clipped pixels bias the levels and the profile: refuse rather than guess.
  if (options.saturation_level > 0) {
    const double ext = m.half_length_px + m.half_width_px;
    const cv::Rect box(static_cast<int>(std::floor(mid_x - ext)),
                       static_cast<int>(std::floor(mid_y - ext)),
                       static_cast<int>(2 * ext) + 2, static_cast<int>(2 * ext) + 2);
    const cv::Rect roi = box & cv::Rect(0, 0, image.cols, image.rows);
    double max_value = 0;
    cv::minMaxLoc(image(roi), nullptr, &max_value);
    if (max_value >= options.saturation_level) {
      m.status = kEdgeClipped;
      m.message = "pixels near the edge reach the saturation level " +
                  fmt(options.saturation_level) + "; reduce the exposure";
      m.apparent_diameter_px = m.fit.diameter_px;
      return m;
    }
  }

  m.apparent_diameter_px = m.fit.diameter_px;
  m.rms_residual = m.fit.rms_residual;
  m.contrast_to_noise = m.fit.contrast_to_noise;
  double sigma = m.fit.diameter_sigma_px;
  auto inv = remove_baseline_blur(m.apparent_diameter_px, options.baseline_sigma_px,
                                  m.fit.angle_rad);
  if (!inv) {
    m.status = kEdgeFitFailed;
    m.message = "baseline removal: " + inv.error().message;
    return m;
  }
  m.diameter_px = inv->diameter_px;
  m.diameter_sigma_px = std::isfinite(sigma) ? sigma / inv->slope : kInf;
  const double half = options.confidence_sigmas * m.diameter_sigma_px;
  m.ci_low_px = std::isfinite(half) ? std::max(0.0, m.diameter_px - half) : 0.0;
  m.ci_high_px = std::isfinite(half) ? m.diameter_px + half : kInf;
  if (inv->at_baseline) {
    // The fit reads no more than the baseline alone: an upper bound from the noise.
    const double sigma_app = std::isfinite(sigma) ? sigma : 0.0;
    auto bound = remove_baseline_blur(
        inv->apparent_at_zero_px + options.confidence_sigmas * sigma_app,
        options.baseline_sigma_px, m.fit.angle_rad);
    m.ci_high_px = bound ? bound->diameter_px : kInf;
    m.status = kEdgeAtBaseline;
    m.message = "apparent diameter " + fmt(m.apparent_diameter_px) +
                " px is at or below the baseline blur's " + fmt(inv->apparent_at_zero_px) +
                " px: in focus (D <= " + fmt(m.ci_high_px) + " px)";
    return m;
  }
  if (options.airy_diameter_px > 0 && m.diameter_px < options.airy_diameter_px) {
    m.status = kEdgeBelowDiffraction;
    m.message = "diameter " + fmt(m.diameter_px) + " px is below the diffraction floor " +
                fmt(options.airy_diameter_px) + " px (2.44 lambda N): not a measurement";
    return m;
  }
  m.status = kEdgeOk;
  return m;
}

}  // namespace camlab::analysis
