// Synthetic board views of a camera rig with known lenses and poses: each rig view is one
// board pose in the reference frame (camera 0's), aimed at a random pixel of a random
// camera, observed by every camera through its truth lens (synthetic_views.h's observe:
// mrcal_project, Gaussian noise, corners off the imager missing). Independent of the rig
// solver: it composes poses with OpenCV's Rodrigues, not with calib/rig's helpers.
#pragma once

#include <array>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "calib/rig/rig_range.h"
#include "calib/rig/rig_solver.h"
#include "synthetic_views.h"

namespace camlab::calib::testing {

struct RigCameraTruth {
  LensModel lens;
  std::array<double, 6> rt_cam_ref{};  // reference (camera 0) -> camera
};

struct RigViewSpec {
  int views = 30;
  double distance_min_m = 0.5, distance_max_m = 1.2;
  double max_tilt_deg = 40;
  double noise_px = 0.3;
  uint32_t seed = 1;
};

// x_a = R x_b + t: the pose a <- b as a 4x4 matrix, and back.
inline cv::Matx44d rt_matrix(const std::array<double, 6>& rt) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  return {R(0, 0), R(0, 1), R(0, 2), rt[3], R(1, 0), R(1, 1), R(1, 2), rt[4],
          R(2, 0), R(2, 1), R(2, 2), rt[5], 0,       0,       0,       1};
}

inline std::array<double, 6> matrix_rt(const cv::Matx44d& m) {
  const cv::Matx33d R(m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1),
                      m(2, 2));
  cv::Vec3d r;
  cv::Rodrigues(R, r);
  return {r[0], r[1], r[2], m(0, 3), m(1, 3), m(2, 3)};
}

inline RigData make_rig_views(const std::vector<RigCameraTruth>& rig, const BoardSpec& board,
                              const RigViewSpec& spec) {
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<double> u01(0, 1);
  const int n = static_cast<int>(rig.size());
  RigData data;
  for (const auto& cam : rig) {
    CalibrationData d;
    d.board = board;
    d.imager_width_px = cam.lens.width_px;
    d.imager_height_px = cam.lens.height_px;
    data.cameras.push_back(d);
  }
  int attempts = 0;
  while (static_cast<int>(data.cameras[0].views.size()) < spec.views &&
         attempts++ < 200 * spec.views) {
    const int aim_cam = std::min(n - 1, static_cast<int>(u01(rng) * n));
    const LensModel& lens = rig[aim_cam].lens;
    auto dir = unproject(
        lens, {(0.1 + 0.8 * u01(rng)) * lens.width_px, (0.1 + 0.8 * u01(rng)) * lens.height_px});
    if (!dir) continue;
    const double dist =
        spec.distance_min_m + (spec.distance_max_m - spec.distance_min_m) * u01(rng);
    const double tilt = spec.max_tilt_deg * u01(rng) * M_PI / 180, az = 2 * M_PI * u01(rng);
    const double roll = (u01(rng) - 0.5) * 40 * M_PI / 180;
    const auto rt_aim_board = pose_facing(cv::Vec3d((*dir)[0], (*dir)[1], (*dir)[2]) * dist,
                                          tilt * std::cos(az), tilt * std::sin(az), roll, board);
    const cv::Matx44d ref_board =
        rt_matrix(rig[aim_cam].rt_cam_ref).inv() * rt_matrix(rt_aim_board);
    std::vector<BoardView> seen;
    int cameras_seeing = 0;
    for (int c = 0; c < n; ++c) {
      const auto rt = matrix_rt(rt_matrix(rig[c].rt_cam_ref) * ref_board);
      seen.push_back(observe(rig[c].lens, board, rt, spec.noise_px, 0, rng,
                             "view" + std::to_string(data.cameras[0].views.size())));
      cameras_seeing += seen.back().present_count() >= board.cols * board.rows / 3;
    }
    if (cameras_seeing == 0) continue;
    for (int c = 0; c < n; ++c) {
      // A camera that sees less than a third of the board does not report it (a detector
      // would not find it), so the views of each camera differ.
      if (seen[c].present_count() < board.cols * board.rows / 3)
        for (auto& corner : seen[c].corners) corner.present = false;
      data.cameras[c].views.push_back(seen[c]);
    }
  }
  return data;
}

// The pair: a 640x480 camera and a 1280x800 one 0.2 m to its right, turned 5 deg
// towards it (plus `camera1_extra_yaw_deg`) and rolled 1 deg.
inline std::vector<RigCameraTruth> stereo_pair_truth(double camera1_extra_yaw_deg = 0) {
  const double deg = M_PI / 180;
  return {{{"LENSMODEL_OPENCV4", {520, 520, 319.5, 239.5, -0.1, 0.02, 0.0002, -0.0001}, 640, 480},
           {0, 0, 0, 0, 0, 0}},
          {{"LENSMODEL_OPENCV4", {733, 733, 641.5, 398.5, -0.2, 0.04, 0.0, 0.0}, 1280, 800},
           {0.002, (-5 + camera1_extra_yaw_deg) * deg, 1 * deg, -0.2, 0.003, 0.01}}};
}

// Four wide OPENCV8 cameras on a ring, `step_deg` apart, each 0.1 m from the ring's centre
// looking outwards along its yaw.
inline std::vector<RigCameraTruth> ring_truth(double step_deg) {
  std::vector<RigCameraTruth> truth;
  for (int c = 0; c < 4; ++c) {
    const double yaw = c * step_deg * M_PI / 180;
    const cv::Vec3d centre(0.1 * std::sin(yaw), 0, 0.1 * std::cos(yaw) - 0.1);
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(0, -yaw, 0), R);  // ref -> camera
    const cv::Vec3d t = -(R * centre);
    truth.push_back({wide_opencv8_truth(), {0, -yaw, 0, t[0], t[1], t[2]}});
  }
  return truth;
}

// The ring: ring_truth(step_deg) with camera `fisheye` a 180 deg fisheye
// (stereographic, r = 2 f tan(theta / 2), f 320 px across 1280 px) in place of its wide lens.
inline std::vector<RigCameraTruth> ring_with_fisheye_truth(double step_deg, int fisheye) {
  auto truth = ring_truth(step_deg);
  truth[fisheye].lens = {"LENSMODEL_STEREOGRAPHIC", {320, 320, 639.5, 399.5}, 1280, 800};
  return truth;
}

// The truth's rt with its rotation vector written nearest `near`'s: a turn by pi about an
// axis is both +pi and -pi (the ring's camera 3 looks backwards), and turns 2 pi apart are
// one turn; errors are taken in the solution's chart.
inline Rt rt_nearest(Rt truth, const Rt& near) {
  const double angle = std::hypot(truth[0], truth[1], truth[2]);
  if (angle < 1e-9) return truth;
  Rt best = truth;
  double best_distance = 1e300;
  for (int turns = -1; turns <= 1; ++turns) {
    Rt candidate = truth;
    for (int k = 0; k < 3; ++k) candidate[k] = truth[k] * (1 + turns * 2 * M_PI / angle);
    const double d =
        std::hypot(candidate[0] - near[0], candidate[1] - near[1], candidate[2] - near[2]);
    if (d < best_distance) {
      best_distance = d;
      best = candidate;
    }
  }
  return best;
}

// The truth's lenses and poses in a solution (`shape`'s other fields kept).
inline RigSolution truth_solution(const std::vector<RigCameraTruth>& truth,
                                  RigSolution shape = {}) {
  shape.cameras.resize(truth.size());
  for (size_t c = 0; c < truth.size(); ++c) {
    shape.cameras[c].model = truth[c].lens;
    shape.cameras[c].rt_cam_ref = truth[c].rt_cam_ref;
  }
  return shape;
}

// A point `range_m` along camera 0's axis, triangulated with `camera` from its true pixels
// through `solved`: the range error (mm) the calibration makes. Nothing when the point is
// outside the camera's view.
inline std::optional<double> range_error_mm(const RigSolution& solved,
                                            const std::vector<RigCameraTruth>& truth, int camera,
                                            double range_m) {
  const auto exact = triangulated_range_uncertainty(truth_solution(truth, solved), camera, range_m);
  if (!exact) return std::nullopt;
  const RigCamera& other = solved.cameras[camera];
  const auto p = triangulate_midpoint(solved.cameras[0].model, other.model, other.rt_cam_ref,
                                      exact->pixel_camera0, exact->pixel_other);
  if (!p) return std::nullopt;
  return (std::sqrt((*p)[0] * (*p)[0] + (*p)[1] * (*p)[1] + (*p)[2] * (*p)[2]) - range_m) * 1000;
}

}  // namespace camlab::calib::testing
