// Synthetic chessboard observations from a known lens (mrcal's own testing style): board
// poses drawn with a fixed seed, corners projected through the truth model with
// mrcal_project, Gaussian pixel noise added, corners off the imager marked missing.
// Shared by the unit tests, the stability suite and the benchmark.
#pragma once

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "calib/calibration_data.h"
#include "calib/lens_model.h"

namespace camlab::calib::testing {

struct ViewSetSpec {
  int views = 30;
  double distance_min_m = 0.4, distance_max_m = 1.0;  // board centre's range
  double max_tilt_deg = 40;  // tilt of the board normal off the line of sight
  double min_tilt_deg = 0;
  double centre_fraction = 0.9;  // board centres aimed within this central share of the imager
  double noise_px = 0.2;         // Gaussian sigma per coordinate
  double outlier_share = 0;      // corners displaced by 5-30 px
  bool keep_partial = true;      // keep views with off-imager corners (those are missing)
  uint32_t seed = 1;
};

inline LensModel wide_opencv8_truth() {
  // mock_device/examples/camera_wide_1280x800.json at its nominal focus: f 2.2 mm, 3 um px.
  return {"LENSMODEL_OPENCV8",
          {733.3333333333334, 733.3333333333334, 642.3, 398.1, -0.22, 0.05, 0.0004, -0.0003, -0.003,
           0.05, 0.01, 0.0},
          1280,
          800};
}

// Rotation vector of R = Rz(roll) * Ry(b) * Rx(a) composed with the aim rotation.
inline std::array<double, 6> pose_facing(const cv::Vec3d& centre_cam, double tilt_x_rad,
                                         double tilt_y_rad, double roll_rad, const BoardSpec& b) {
  // Start with the board facing the camera along the line of sight, then tilt.
  cv::Vec3d z = centre_cam / cv::norm(centre_cam);
  cv::Vec3d x = cv::Vec3d(1, 0, 0) - z * z[0];
  x /= cv::norm(x);
  cv::Vec3d y = z.cross(x);
  cv::Matx33d aim(x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]);
  cv::Matx33d tilt;
  cv::Rodrigues(cv::Vec3d(tilt_x_rad, tilt_y_rad, roll_rad), tilt);
  cv::Matx33d R = aim * tilt;
  const cv::Vec3d half(0.5 * (b.cols - 1) * b.spacing_m, 0.5 * (b.rows - 1) * b.spacing_m, 0);
  const cv::Vec3d t = centre_cam - R * half;
  cv::Vec3d r;
  cv::Rodrigues(R, r);
  return {r[0], r[1], r[2], t[0], t[1], t[2]};
}

// Projects the board in pose rt through `truth`; corners behind the camera or off the
// imager are missing. Noise and outliers come from `rng`.
inline BoardView observe(const LensModel& truth, const BoardSpec& b,
                         const std::array<double, 6>& rt, double noise_px, double outlier_share,
                         std::mt19937& rng, const std::string& name) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  std::vector<double> p;
  for (int j = 0; j < b.rows; ++j)
    for (int i = 0; i < b.cols; ++i) {
      const cv::Vec3d q =
          R * cv::Vec3d(i * b.spacing_m, j * b.spacing_m, 0) + cv::Vec3d(rt[3], rt[4], rt[5]);
      p.insert(p.end(), {q[0], q[1], q[2]});
    }
  auto q = project(truth, p);
  // A polynomial lens model folds over beyond its useful field: a point there projects to
  // a pixel that unprojects to another direction. A real lens images no such point, so
  // corners whose projection does not unproject back to them are not observed.
  std::vector<char> valid;
  std::vector<double> dirs;
  if (q) {
    auto d = unproject_each(truth, *q, &valid);
    if (d) dirs = std::move(*d);
  }
  std::normal_distribution<double> noise(0, noise_px);
  std::uniform_real_distribution<double> u01(0, 1);
  BoardView v;
  v.name = name;
  for (int k = 0; k < b.cols * b.rows; ++k) {
    CornerObservation c;
    const double x = q ? (*q)[2 * k] : -1, y = q ? (*q)[2 * k + 1] : -1;
    c.present = q.ok() && p[3 * k + 2] > 0 && x >= 0 && y >= 0 && x <= truth.width_px - 1 &&
                y <= truth.height_px - 1;
    if (c.present) {
      const double n = std::sqrt(p[3 * k] * p[3 * k] + p[3 * k + 1] * p[3 * k + 1] +
                                 p[3 * k + 2] * p[3 * k + 2]);
      const double dot = dirs.empty() || !valid[k]
                             ? 0.0
                             : (dirs[3 * k] * p[3 * k] + dirs[3 * k + 1] * p[3 * k + 1] +
                                dirs[3 * k + 2] * p[3 * k + 2]) /
                                   n;
      c.present = dot > std::cos(1e-5);
    }
    c.x_px = x + noise(rng);
    c.y_px = y + noise(rng);
    if (outlier_share > 0 && u01(rng) < outlier_share) {
      const double mag = 5 + 25 * u01(rng), ang = 2 * M_PI * u01(rng);
      c.x_px += mag * std::cos(ang);
      c.y_px += mag * std::sin(ang);
    }
    v.corners.push_back(c);
  }
  return v;
}

inline CalibrationData make_views(const LensModel& truth, const BoardSpec& board,
                                  const ViewSetSpec& spec,
                                  std::vector<std::array<double, 6>>* poses_out = nullptr) {
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<double> u01(0, 1);
  CalibrationData data;
  data.board = board;
  data.imager_width_px = truth.width_px;
  data.imager_height_px = truth.height_px;
  int attempts = 0;
  while (static_cast<int>(data.views.size()) < spec.views && attempts++ < 100 * spec.views) {
    const double fx = 0.5 + (u01(rng) - 0.5) * spec.centre_fraction;
    const double fy = 0.5 + (u01(rng) - 0.5) * spec.centre_fraction;
    auto dir = unproject(truth, {fx * truth.width_px, fy * truth.height_px});
    if (!dir) continue;
    const double dist =
        spec.distance_min_m + (spec.distance_max_m - spec.distance_min_m) * u01(rng);
    const cv::Vec3d centre = cv::Vec3d((*dir)[0], (*dir)[1], (*dir)[2]) * dist;
    // Tilt magnitude in [min, max], random direction; roll up to +-20 deg.
    const double tilt =
        (spec.min_tilt_deg + (spec.max_tilt_deg - spec.min_tilt_deg) * u01(rng)) * M_PI / 180;
    const double az = 2 * M_PI * u01(rng);
    const double roll = (u01(rng) - 0.5) * 40 * M_PI / 180;
    auto rt = pose_facing(centre, tilt * std::cos(az), tilt * std::sin(az), roll, board);
    BoardView v = observe(truth, board, rt, spec.noise_px, spec.outlier_share, rng,
                          "view" + std::to_string(data.views.size()) + ".png");
    const int present = v.present_count();
    if (present < (spec.keep_partial ? board.cols * board.rows / 3 : board.cols * board.rows))
      continue;
    data.views.push_back(std::move(v));
    if (poses_out) poses_out->push_back(rt);
  }
  return data;
}

}  // namespace camlab::calib::testing
