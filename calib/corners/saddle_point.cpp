#include "calib/corners/saddle_point.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace camlab::calib {

namespace {

constexpr int kMaxIterations = 30;
constexpr double kToleranceSq = 1e-4 * 1e-4;  // (px)^2: a step this small ends the iteration

// The weighted least-squares quadratic over the window around c (coordinates relative to
// c, in units of the radius, so the normal equations stay well conditioned). False when
// the system is singular.
bool fit_quadratic(const cv::Mat& image, cv::Point2d c, double radius, cv::Vec6d* coef) {
  const int x0 = static_cast<int>(std::ceil(c.x - radius)), x1 = static_cast<int>(c.x + radius);
  const int y0 = static_cast<int>(std::ceil(c.y - radius)), y1 = static_cast<int>(c.y + radius);
  cv::Matx66d ata = cv::Matx66d::zeros();
  cv::Vec6d atb(0, 0, 0, 0, 0, 0);
  const double inv_r = 1.0 / radius;
  for (int y = y0; y <= y1; ++y) {
    const float* row = image.ptr<float>(y);
    const double dy = (y - c.y) * inv_r;
    for (int x = x0; x <= x1; ++x) {
      const double dx = (x - c.x) * inv_r;
      const double r2 = dx * dx + dy * dy;
      if (r2 >= 1) continue;
      const double w = (1 - r2) * (1 - r2);
      const double b[6] = {1, dx, dy, dx * dx, dx * dy, dy * dy};
      const double v = row[x];
      for (int i = 0; i < 6; ++i) {
        const double wb = w * b[i];
        atb[i] += wb * v;
        for (int j = i; j < 6; ++j) ata(i, j) += wb * b[j];
      }
    }
  }
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < i; ++j) ata(i, j) = ata(j, i);
  return cv::solve(ata, atb, *coef, cv::DECOMP_CHOLESKY);
}

}  // namespace

Result<SaddleRefinement> refine_saddle_point(const cv::Mat& image, cv::Point2d start,
                                             double radius_px, double max_move_px) {
  if (image.empty() || image.channels() != 1)
    return make_error("bad_image", "saddle-point refinement needs a single-channel image");
  if (!(radius_px >= 2))
    return make_error("window_too_small", "the saddle-point window's radius is " +
                                              std::to_string(radius_px) + " px; at least 2 px");
  cv::Mat f;
  if (image.depth() == CV_32F)
    f = image;
  else
    image.convertTo(f, CV_32F);
  SaddleRefinement out;
  cv::Point2d c = start;
  for (int it = 1; it <= kMaxIterations; ++it) {
    if (!(c.x - radius_px >= 0 && c.y - radius_px >= 0 && c.x + radius_px <= f.cols - 1 &&
          c.y + radius_px <= f.rows - 1))
      return make_error(
          "window_outside_image",
          "the saddle-point window (radius " + std::to_string(radius_px) + " px) leaves the image");
    cv::Vec6d k;
    if (!fit_quadratic(f, c, radius_px, &k))
      return make_error("not_converged", "the saddle-point fit is singular");
    // Gradient zero: [2 c3, c4; c4, 2 c5] d = -[c1, c2], in units of the radius.
    const double hxx = 2 * k[3], hxy = k[4], hyy = 2 * k[5];
    const double det = hxx * hyy - hxy * hxy;
    if (!(det < 0))
      return make_error("not_converged", "the image has no saddle point in the window");
    const double dx = -(hyy * k[1] - hxy * k[2]) / det;
    const double dy = -(hxx * k[2] - hxy * k[1]) / det;
    const cv::Point2d step(dx * radius_px, dy * radius_px);
    // A step out of the window is a fit that does not describe a corner inside it: move
    // at most half the radius at a time.
    const double len = std::hypot(step.x, step.y);
    c += len > 0.5 * radius_px ? step * (0.5 * radius_px / len) : step;
    if (!(std::hypot(c.x - start.x, c.y - start.y) <= max_move_px))
      return make_error("not_converged", "the saddle point moved more than " +
                                             std::to_string(max_move_px) +
                                             " px from the first estimate");
    out.iterations = it;
    // The balance of the Hessian's two eigenvalues (l1 > 0 > l2), |l1 l2| / ((l1 - l2) / 2)^2:
    // 1 for a square corner seen straight on, lower as perspective skews it, near 0 where
    // the window holds one edge.
    const double half_trace = 0.5 * (hxx + hyy);
    out.saddle_strength = -det / (half_trace * half_trace - det);
    if (step.dot(step) < kToleranceSq) {
      out.corner_px = c;
      return out;
    }
  }
  return make_error("not_converged", "the saddle-point iteration did not settle in " +
                                         std::to_string(kMaxIterations) + " steps");
}

}  // namespace camlab::calib
