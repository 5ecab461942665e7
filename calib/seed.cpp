#include "calib/seed.h"
#include "base/log.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <opencv2/calib3d.hpp>

namespace camlab::calib {

namespace {

// Pinhole-normalised coordinates (x/z, y/z) of pixel q under a core-only projection, or
// false beyond 80 deg off-axis (tan explodes; the seed does not need those corners).
bool normalise(SeedProjection proj, double f, double cx, double cy, double qx, double qy, double* x,
               double* y) {
  const double ux = (qx - cx) / f, uy = (qy - cy) / f;
  if (proj == SeedProjection::kPinhole) {
    *x = ux;
    *y = uy;
    return true;
  }
  const double r = std::hypot(ux, uy);
  const double theta = 2 * std::atan(r / 2);
  if (theta > 80.0 * M_PI / 180.0) return false;
  const double s = r > 1e-12 ? std::tan(theta) / r : 1.0;
  *x = ux * s;
  *y = uy * s;
  return true;
}

void project_core(SeedProjection proj, double f, double cx, double cy, const cv::Point3d& p,
                  double* qx, double* qy) {
  if (proj == SeedProjection::kPinhole) {
    *qx = cx + f * p.x / p.z;
    *qy = cy + f * p.y / p.z;
    return;
  }
  // mrcal's stereographic projection: u = 2 p_xy / (|p| + z).
  const double norm = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
  const double d = norm + p.z;
  *qx = cx + f * 2 * p.x / d;
  *qy = cy + f * 2 * p.y / d;
}

bool solve_pnp(const std::vector<cv::Point3d>& board, const std::vector<cv::Point2d>& normalised,
               cv::Vec3d* r, cv::Vec3d* t) {
  if (normalised.size() < 6) return false;
  try {
    if (!cv::solvePnP(board, normalised, cv::Matx33d::eye(), cv::noArray(), *r, *t, false,
                      cv::SOLVEPNP_IPPE))
      return false;
  } catch (const cv::Exception&) {
    return false;
  }
  return (*t)[2] > 0 && std::isfinite((*t)[2]) && std::isfinite((*r)[0]);
}

cv::Point3d board_point(const BoardSpec& b, int k) {
  return {(k % b.cols) * b.spacing_m, (k / b.cols) * b.spacing_m, 0.0};
}

// Robust cost of one candidate: per corner min(e, cap)^2, summed over the views.
double candidate_cost(const CalibrationData& data, const std::vector<int>& views,
                      SeedProjection proj, double f) {
  const double cx = (data.imager_width_px - 1) / 2.0, cy = (data.imager_height_px - 1) / 2.0;
  const double cap = 0.01 * std::hypot(data.imager_width_px, data.imager_height_px);
  double cost = 0;
  for (int v : views) {
    const auto& corners = data.views[v].corners;
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    std::vector<int> idx;
    for (int k = 0; k < static_cast<int>(corners.size()); ++k) {
      if (!corners[k].present) continue;
      double x, y;
      if (!normalise(proj, f, cx, cy, corners[k].x_px, corners[k].y_px, &x, &y)) continue;
      obj.push_back(board_point(data.board, k));
      img.emplace_back(x, y);
      idx.push_back(k);
    }
    cv::Vec3d r, t;
    const int present = data.views[v].present_count();
    if (!solve_pnp(obj, img, &r, &t)) {
      cost += present * cap * cap;
      continue;
    }
    cv::Matx33d R;
    cv::Rodrigues(r, R);
    for (int k = 0; k < static_cast<int>(corners.size()); ++k) {
      if (!corners[k].present) continue;
      const cv::Point3d p = R * board_point(data.board, k) + cv::Point3d(t);
      double qx = 0, qy = 0;
      double e = cap;
      if (p.z > 0 || proj == SeedProjection::kStereographic) {
        project_core(proj, f, cx, cy, p, &qx, &qy);
        e = std::min(cap, std::hypot(qx - corners[k].x_px, qy - corners[k].y_px));
        if (!std::isfinite(e)) e = cap;
      }
      cost += e * e;
    }
  }
  return cost;
}

}  // namespace

std::optional<FocalSeed> seed_focal(const CalibrationData& data, double focal_guess_px) {
  // Up to 8 views, the best-populated first, keep the sweep cheap.
  std::vector<int> views;
  for (int v = 0; v < static_cast<int>(data.views.size()); ++v)
    if (data.views[v].present_count() >= 8) views.push_back(v);
  if (views.empty()) return std::nullopt;
  std::stable_sort(views.begin(), views.end(), [&](int a, int b) {
    return data.views[a].present_count() > data.views[b].present_count();
  });
  if (views.size() > 8) views.resize(8);

  const double diag = std::hypot(data.imager_width_px, data.imager_height_px);
  std::vector<double> candidates;
  for (int k = -12; k <= 16; ++k) candidates.push_back(diag * std::pow(2.0, k / 4.0));
  if (focal_guess_px > 0)
    for (int k = -2; k <= 2; ++k) candidates.push_back(focal_guess_px * std::pow(2.0, k / 8.0));

  FocalSeed best;
  best.cost = INFINITY;
  for (SeedProjection proj : {SeedProjection::kPinhole, SeedProjection::kStereographic})
    for (double f : candidates) {
      const double c = candidate_cost(data, views, proj, f);
      if (c < best.cost) best = {f, proj, c};
    }
  if (!std::isfinite(best.cost)) return std::nullopt;
  // Golden-section refinement in log f over the neighbouring grid steps.
  const double g = (std::sqrt(5.0) - 1) / 2;
  double a = std::log(best.focal_px) - std::log(2.0) / 4,
         b = std::log(best.focal_px) + std::log(2.0) / 4;
  double x1 = b - g * (b - a), x2 = a + g * (b - a);
  double f1 = candidate_cost(data, views, best.projection, std::exp(x1));
  double f2 = candidate_cost(data, views, best.projection, std::exp(x2));
  for (int it = 0; it < 14; ++it) {
    if (f1 < f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - g * (b - a);
      f1 = candidate_cost(data, views, best.projection, std::exp(x1));
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + g * (b - a);
      f2 = candidate_cost(data, views, best.projection, std::exp(x2));
    }
  }
  const double x = f1 < f2 ? x1 : x2;
  const double c = std::min(f1, f2);
  if (c < best.cost) {
    best.focal_px = std::exp(x);
    best.cost = c;
  }
  return best;
}

std::optional<std::array<double, 6>> pose_from_corners(const CalibrationData& data, int view,
                                                       const LensModel& model) {
  const auto& corners = data.views[view].corners;
  std::vector<double> q;
  std::vector<int> idx;
  for (int k = 0; k < static_cast<int>(corners.size()); ++k)
    if (corners[k].present) {
      q.push_back(corners[k].x_px);
      q.push_back(corners[k].y_px);
      idx.push_back(k);
    }
  std::vector<char> valid;
  auto dirs = unproject_each(model, q, &valid);
  if (!dirs) {
    log_debug(log::Category::kCalib, "view %d: %s", view, dirs.error().message.c_str());
    return std::nullopt;
  }
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  const double cos80 = std::cos(80.0 * M_PI / 180.0);
  for (size_t i = 0; i < idx.size(); ++i) {
    const double* d = &(*dirs)[3 * i];
    if (!valid[i] || d[2] < cos80) continue;
    obj.push_back(board_point(data.board, idx[i]));
    img.emplace_back(d[0] / d[2], d[1] / d[2]);
  }
  cv::Vec3d r, t;
  if (!solve_pnp(obj, img, &r, &t)) {
    log_debug(log::Category::kCalib, "view %d: pnp failed with %zu points", view, obj.size());
    return std::nullopt;
  }
  return std::array<double, 6>{r[0], r[1], r[2], t[0], t[1], t[2]};
}

}  // namespace camlab::calib
