// Views that run off the imager's edges against the same views moved until the board is
// whole (docs/calibration.md, "Partial views at the imager's edges"). Shared by the
// stability test and the benchmark.
//
// The plan: `views` board poses, most aimed at points on the imager's border (so about
// half of each board is cut off by the frame), the rest inside. The whole-board twin of
// a pose is the same board turned about the camera's centre towards the optical axis by
// the smallest angle (bisection) that puts its outer squares' outline on the imager: the
// board keeps its distance and its tilt against the line of sight, only where it sits in
// the image changes, as when a user re-aims a board a whole-board detector missed. A
// board too big for the imager even when centred is moved back along its line of sight.
//
// The truth comparison projects directions through the truth and the fit without fitting
// a rotation between them: the camera frame of the synthetic poses is the fit's.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "synthetic_views.h"

namespace camlab::calib::testing {

// Whether the board's outline (the outer squares' outer corners, one spacing beyond the
// inner corners) projects onto the imager: what a whole-board detector needs.
inline bool board_whole(const LensModel& truth, const BoardSpec& b,
                        const std::array<double, 6>& rt) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  std::vector<double> p;
  // The outline's edges, sampled: a distorted straight edge may bow off the imager
  // between its ends.
  for (int k = 0; k <= 8; ++k) {
    const double s = -1 + (b.cols + 1) * k / 8.0, t = -1 + (b.rows + 1) * k / 8.0;
    for (const auto& ij :
         {cv::Vec2d(s, -1), cv::Vec2d(s, b.rows), cv::Vec2d(-1, t), cv::Vec2d(b.cols, t)}) {
      const cv::Vec3d q = R * cv::Vec3d(ij[0] * b.spacing_m, ij[1] * b.spacing_m, 0) +
                          cv::Vec3d(rt[3], rt[4], rt[5]);
      if (q[2] <= 0) return false;
      p.insert(p.end(), {q[0], q[1], q[2]});
    }
  }
  auto q = project(truth, p);
  if (!q) return false;
  for (size_t i = 0; i < q->size() / 2; ++i) {
    const double x = (*q)[2 * i], y = (*q)[2 * i + 1];
    if (!(x >= 0 && y >= 0 && x <= truth.width_px - 1 && y <= truth.height_px - 1)) return false;
  }
  return true;
}

// The pose turned about the camera's centre by `fraction` of the rotation that takes the
// board's centre onto the optical axis, then moved back along its line of sight by `back`.
inline std::array<double, 6> turned_towards_axis(const std::array<double, 6>& rt,
                                                 const BoardSpec& b, double fraction,
                                                 double back = 1.0) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  const cv::Vec3d t(rt[3], rt[4], rt[5]);
  const cv::Vec3d half(0.5 * (b.cols - 1) * b.spacing_m, 0.5 * (b.rows - 1) * b.spacing_m, 0);
  const cv::Vec3d centre = R * half + t;
  const cv::Vec3d dir = centre / cv::norm(centre);
  cv::Vec3d axis = dir.cross(cv::Vec3d(0, 0, 1));
  const double s = cv::norm(axis);
  cv::Matx33d Q = cv::Matx33d::eye();
  if (s > 1e-12) {
    const double angle = std::atan2(s, dir[2]) * fraction;
    cv::Rodrigues(cv::Vec3d(axis * (angle / s)), Q);
  }
  const cv::Matx33d R2 = Q * R;
  const cv::Vec3d centre2 = Q * centre * back;
  const cv::Vec3d t2 = centre2 - R2 * half;
  cv::Vec3d r2;
  cv::Rodrigues(R2, r2);
  return {r2[0], r2[1], r2[2], t2[0], t2[1], t2[2]};
}

// The whole-board twin of a pose (the pose itself when its board is whole already).
inline std::array<double, 6> whole_twin(const LensModel& truth, const BoardSpec& b,
                                        const std::array<double, 6>& rt) {
  if (board_whole(truth, b, rt)) return rt;
  double back = 1.0;
  while (!board_whole(truth, b, turned_towards_axis(rt, b, 1.0, back)) && back < 8) back *= 1.1;
  double lo = 0, hi = 1;  // lo: not whole; hi: whole
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (lo + hi);
    (board_whole(truth, b, turned_towards_axis(rt, b, mid, back)) ? hi : lo) = mid;
  }
  return turned_towards_axis(rt, b, hi, back);
}

struct BorderPlan {
  int views = 30;
  int border_views = 20;  // aimed at points spaced evenly along the imager's border
  double distance_min_m = 0.5, distance_max_m = 0.8;
  double max_tilt_deg = 35;
  double noise_px = 0.2;
  uint32_t seed = 7;
  // The board point aimed at the plan's image points (board frame, m; default: the board's
  // centre) and how far inside the border those points lie (px). A board with markers
  // aims its marker square a little inside, so the markers stay in view.
  std::optional<std::array<double, 2>> aim_board_m;
  double inset_px = 0;
};

// The poses of a border plan: board centres aimed along the border, then inside.
inline std::vector<std::array<double, 6>> border_plan_poses(const LensModel& truth,
                                                            const BoardSpec& b,
                                                            const BorderPlan& plan) {
  std::mt19937 rng(plan.seed);
  std::uniform_real_distribution<double> u01(0, 1);
  const double w = truth.width_px - 1, h = truth.height_px - 1;
  std::vector<std::array<double, 6>> poses;
  for (int k = 0; k < plan.views; ++k) {
    double x, y;
    if (k < plan.border_views) {
      // A point at perimeter fraction s, walking the border clockwise from the top-left.
      const double s = (k + 0.5) / plan.border_views * 2 * (w + h);
      const double in = plan.inset_px;
      if (s < w)
        x = s, y = in;
      else if (s < w + h)
        x = w - in, y = s - w;
      else if (s < 2 * w + h)
        x = 2 * w + h - s, y = h - in;
      else
        x = in, y = 2 * (w + h) - s;
      x = std::clamp(x, in, w - in);
      y = std::clamp(y, in, h - in);
    } else {
      x = (0.2 + 0.6 * u01(rng)) * w;
      y = (0.2 + 0.6 * u01(rng)) * h;
    }
    auto dir = unproject(truth, {x, y});
    if (!dir) continue;
    const double dist =
        plan.distance_min_m + (plan.distance_max_m - plan.distance_min_m) * u01(rng);
    const cv::Vec3d centre = cv::Vec3d((*dir)[0], (*dir)[1], (*dir)[2]) * dist;
    const double tilt = plan.max_tilt_deg * u01(rng) * M_PI / 180, az = 2 * M_PI * u01(rng);
    const double roll = (u01(rng) - 0.5) * 40 * M_PI / 180;
    auto rt = pose_facing(centre, tilt * std::cos(az), tilt * std::sin(az), roll, b);
    if (plan.aim_board_m) {
      // Slide the board in its plane so the aimed point, not its centre, is at `centre`.
      cv::Matx33d R;
      cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
      const cv::Vec3d half(0.5 * (b.cols - 1) * b.spacing_m, 0.5 * (b.rows - 1) * b.spacing_m, 0);
      const cv::Vec3d aim((*plan.aim_board_m)[0], (*plan.aim_board_m)[1], 0);
      const cv::Vec3d t = cv::Vec3d(rt[3], rt[4], rt[5]) + R * (half - aim);
      rt = {rt[0], rt[1], rt[2], t[0], t[1], t[2]};
    }
    poses.push_back(rt);
  }
  return poses;
}

// Observations of `poses` (corners off the imager missing), noise from a fixed seed.
inline CalibrationData observe_poses(const LensModel& truth, const BoardSpec& b,
                                     const std::vector<std::array<double, 6>>& poses,
                                     double noise_px, uint32_t seed) {
  std::mt19937 rng(seed);
  CalibrationData data;
  data.board = b;
  data.imager_width_px = truth.width_px;
  data.imager_height_px = truth.height_px;
  for (size_t k = 0; k < poses.size(); ++k)
    data.views.push_back(
        observe(truth, b, poses[k], noise_px, 0, rng, "view" + std::to_string(k) + ".png"));
  return data;
}

// Projection error of `fit` against `truth` (px): each pixel unprojected through the
// truth and projected through the fit, at the imager's four corner pixels and at points
// every `step_px` along its border (corners included).
struct BorderError {
  double corners_rms_px = 0, corners_max_px = 0;
  double border_rms_px = 0, border_max_px = 0;
  int border_points = 0;
};

inline BorderError border_error(const LensModel& truth, const LensModel& fit, double step_px = 40) {
  const double w = truth.width_px - 1, h = truth.height_px - 1;
  std::vector<double> corners = {0, 0, w, 0, w, h, 0, h}, border;
  for (double x = 0; x < w; x += step_px) border.insert(border.end(), {x, 0, w - x, h});
  for (double y = 0; y < h; y += step_px) border.insert(border.end(), {w, y, 0, h - y});
  auto error = [&](const std::vector<double>& q, double* rms, double* max) {
    *rms = *max = INFINITY;  // a model that cannot project there
    auto d = unproject(truth, q);
    if (!d) return;
    auto back = project(fit, *d);
    if (!back) return;
    double sum = 0;
    *max = 0;
    for (size_t i = 0; i < q.size() / 2; ++i) {
      const double e = std::hypot((*back)[2 * i] - q[2 * i], (*back)[2 * i + 1] - q[2 * i + 1]);
      sum += e * e;
      *max = std::max(*max, e);
    }
    *rms = std::sqrt(sum / (q.size() / 2));
  };
  BorderError e;
  error(corners, &e.corners_rms_px, &e.corners_max_px);
  error(border, &e.border_rms_px, &e.border_max_px);
  e.border_points = static_cast<int>(border.size() / 2);
  return e;
}

}  // namespace camlab::calib::testing
