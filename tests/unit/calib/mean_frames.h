// mrcal's "mean-frames" reprojection (its test-projection-uncertainty.py), the empirical
// side of the projection uncertainty (calib/uncertainty.h): the point seen at pixel
// (x, y) at distance d through a baseline solve is carried into every board's frame
// through the baseline poses, back through another solve's poses, averaged, and
// projected through that solve's lens (at infinity only the rotations act). Shared by
// the uncertainty test and the benchmark.
#pragma once

#include <array>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "calib/lens_model.h"
#include "calib/solver.h"

namespace camlab::calib::testing {

inline cv::Vec3d transform_rt(const std::array<double, 6>& rt, const cv::Vec3d& p, bool inverse,
                              bool rotate_only) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  const cv::Vec3d t = rotate_only ? cv::Vec3d(0, 0, 0) : cv::Vec3d(rt[3], rt[4], rt[5]);
  return inverse ? R.t() * (p - t) : R * p + t;
}

// Both solves must hold the same views in the same order.
inline cv::Vec2d reproject_mean_frames(const Solution& base, const Solution& s, double x, double y,
                                       double d) {
  auto v = unproject(base.model, {x, y});
  const bool inf = !std::isfinite(d);
  const cv::Vec3d p_cam = cv::Vec3d((*v)[0], (*v)[1], (*v)[2]) * (inf ? 1.0 : d);
  cv::Vec3d mean(0, 0, 0);
  for (size_t i = 0; i < base.rt_cam_board.size(); ++i)
    mean += transform_rt(s.rt_cam_board[i], transform_rt(base.rt_cam_board[i], p_cam, true, inf),
                         false, inf);
  mean *= 1.0 / base.rt_cam_board.size();
  auto q = project(s.model, {mean[0], mean[1], mean[2]});
  return {(*q)[0], (*q)[1]};
}

}  // namespace camlab::calib::testing
