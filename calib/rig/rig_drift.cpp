#include "calib/rig/rig_drift.h"

#include <cmath>
#include <string>

#include <opencv2/core.hpp>

#include "base/format.h"
#include "calib/rig/rig_pose.h"

namespace camlab::calib {

namespace {

Result<Rt> pose_of(const nlohmann::json& camera) {
  try {
    return camera.at("rt_cam_ref").get<Rt>();
  } catch (const nlohmann::json::exception&) {
    return make_error("invalid_argument", "a camera of the report has no rt_cam_ref");
  }
}

Result<cv::Matx66d> covariance_of(const nlohmann::json& camera) {
  try {
    const auto v = camera.at("rt_cam_ref_covariance").get<std::vector<double>>();
    if (v.size() != 36) throw std::out_of_range("size");
    cv::Matx66d m;
    for (int k = 0; k < 36; ++k) m.val[k] = v[k];
    return m;
  } catch (const std::exception&) {
    return make_error("invalid_argument",
                      "a camera of the report has no 6 x 6 rt_cam_ref_covariance");
  }
}

}  // namespace

Result<nlohmann::json> rig_drift(const nlohmann::json& before, const nlohmann::json& after) {
  if (!before.is_object() || !after.is_object() || !before.contains("cameras") ||
      !after.contains("cameras") || !before["cameras"].is_array() || !after["cameras"].is_array())
    return make_error("invalid_argument", "a rig drift compares two rig reports (rig.json)");
  const size_t n = before["cameras"].size();
  if (after["cameras"].size() != n)
    return make_error("invalid_argument",
                      format_printf("the rigs differ: %zu cameras before, %zu after", n,
                                    after["cameras"].size()));
  nlohmann::json cameras = nlohmann::json::array();
  for (size_t c = 1; c < n; ++c) {
    Rt a{}, b{};
    cv::Matx66d ca, cb;
    CAMLAB_ASSIGN(a, pose_of(before["cameras"][c]));
    CAMLAB_ASSIGN(b, pose_of(after["cameras"][c]));
    CAMLAB_ASSIGN(ca, covariance_of(before["cameras"][c]));
    CAMLAB_ASSIGN(cb, covariance_of(after["cameras"][c]));
    cv::Vec<double, 6> d;
    for (int k = 0; k < 6; ++k) d[k] = b[k] - a[k];
    // A rotation vector near pi and its twin -r describe one rotation: compare the twin
    // nearer the first (the branch cut is not a drift).
    const double angle = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    if (angle > 1e-9) {
      Rt twin = b;
      for (int k = 0; k < 3; ++k) twin[k] = b[k] * (1 - 2 * M_PI / angle);
      double dist = 0, dist_twin = 0;
      for (int k = 0; k < 3; ++k) {
        dist += (b[k] - a[k]) * (b[k] - a[k]);
        dist_twin += (twin[k] - a[k]) * (twin[k] - a[k]);
      }
      if (dist_twin < dist)
        for (int k = 0; k < 3; ++k) d[k] = twin[k] - a[k];
    }
    cv::Matx66d inverse;
    if (cv::invert(ca + cb, inverse, cv::DECOMP_CHOLESKY) == 0)
      return make_error(
          "singular", format_printf("camera %zu: the two covariances' sum cannot be inverted", c));
    const double chi_square = d.dot(inverse * d);
    cameras.push_back(
        {{"camera", c},
         {"rotation_deg", rotation_between_deg(a, b)},
         {"translation_mm", 1000 * std::sqrt(d[3] * d[3] + d[4] * d[4] + d[5] * d[5])},
         {"chi_square", chi_square},
         {"threshold", kRigDriftChiSquare6Dof},
         {"verdict", chi_square > kRigDriftChiSquare6Dof ? "moved" : "unchanged"}});
  }
  return nlohmann::json{{"cameras", cameras},
                        {"rule",
                         "chi-square of the pose difference over the two calibrations' "
                         "summed covariance, 6 degrees of freedom; moved above 22.46 "
                         "(0.1% of an unmoved rig's draws)"}};
}

}  // namespace camlab::calib
