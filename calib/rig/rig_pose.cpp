#include "calib/rig/rig_pose.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace camlab::calib {

cv::Matx33d rotation_matrix(const Rt& rt) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  return R;
}

Rt rt_from(const cv::Matx33d& R, const cv::Vec3d& t) {
  cv::Vec3d r;
  cv::Rodrigues(R, r);
  return {r[0], r[1], r[2], t[0], t[1], t[2]};
}

Rt compose_rt(const Rt& rt_a_b, const Rt& rt_b_c) {
  const cv::Matx33d R_ab = rotation_matrix(rt_a_b), R_bc = rotation_matrix(rt_b_c);
  const cv::Vec3d t_ab(rt_a_b[3], rt_a_b[4], rt_a_b[5]), t_bc(rt_b_c[3], rt_b_c[4], rt_b_c[5]);
  return rt_from(R_ab * R_bc, R_ab * t_bc + t_ab);
}

Rt invert_rt(const Rt& rt_a_b) {
  const cv::Matx33d R_ba = rotation_matrix(rt_a_b).t();
  return rt_from(R_ba, -(R_ba * cv::Vec3d(rt_a_b[3], rt_a_b[4], rt_a_b[5])));
}

Rt mean_rt(const std::vector<Rt>& poses) {
  if (poses.empty()) return Rt{};
  cv::Matx33d sum = cv::Matx33d::zeros();
  cv::Vec3d t(0, 0, 0);
  for (const Rt& p : poses) {
    sum += rotation_matrix(p);
    t += cv::Vec3d(p[3], p[4], p[5]);
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(cv::Mat(sum), w, u, vt);
  cv::Mat R = u * vt;
  if (cv::determinant(R) < 0) {  // the nearest rotation, not a reflection
    u.col(2) *= -1;
    R = u * vt;
  }
  return rt_from(cv::Matx33d(R), t * (1.0 / static_cast<double>(poses.size())));
}

double rotation_between_deg(const Rt& a, const Rt& b) {
  const cv::Matx33d d = rotation_matrix(a).t() * rotation_matrix(b);
  const double c = std::clamp((cv::trace(d) - 1) / 2, -1.0, 1.0);
  return std::acos(c) * 180 / M_PI;
}

}  // namespace camlab::calib
