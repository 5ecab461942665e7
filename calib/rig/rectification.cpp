#include "calib/rig/rectification.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include "base/format.h"
#include "calib/mrcal_api.h"

namespace camlab::calib {

namespace {

constexpr double kRadPerDeg = M_PI / 180;

bool is_latlon(const LensModel& m) { return m.lensmodel == "LENSMODEL_LATLON"; }

// A ray of the rectified frame to its rectified pixel; NaN where the model has none (behind
// a pinhole).
cv::Point2d rectified_pixel(const LensModel& m, const cv::Vec3d& d) {
  const auto& k = m.intrinsics;
  if (is_latlon(m)) {
    const mrcal_point3_t v{{d[0], d[1], d[2]}};
    mrcal_point2_t q;
    mrcal_project_latlon(&q, nullptr, &v, 1, k.data());
    return {q.x, q.y};
  }
  if (!(d[2] > 0)) return {std::nan(""), std::nan("")};
  return {k[0] * d[0] / d[2] + k[2], k[1] * d[1] / d[2] + k[3]};
}

// A rectified pixel's ray in the rectified frame.
cv::Vec3d rectified_ray(const LensModel& m, double x, double y) {
  const auto& k = m.intrinsics;
  if (is_latlon(m)) {
    const mrcal_point2_t q{{x, y}};
    mrcal_point3_t v;
    mrcal_unproject_latlon(&v, nullptr, &q, 1, k.data());
    return {v.x, v.y, v.z};
  }
  return {(x - k[2]) / k[0], (y - k[3]) / k[1], 1.0};
}

}  // namespace

RectifiedModel suited_rectified_model(const LensModel& camera0, double az_fov_deg,
                                      double el_fov_deg) {
  auto fov = field_of_view_parts(camera0);
  if (az_fov_deg <= 0 && fov.ok() && fov->horizontal_deg) az_fov_deg = *fov->horizontal_deg;
  if (el_fov_deg <= 0 && fov.ok() && fov->vertical_deg) el_fov_deg = *fov->vertical_deg;
  return std::max(az_fov_deg, el_fov_deg) > 120 ? RectifiedModel::kLatlon
                                                : RectifiedModel::kPinhole;
}

Result<StereoRectification> rectify_pair(const RigSolution& rig, int camera, double az_fov_deg,
                                         double el_fov_deg, RectifiedModel model) {
  const int n = static_cast<int>(rig.cameras.size());
  if (camera < 1 || camera >= n)
    return make_error(
        "out_of_range",
        format_printf("camera %d: the pair is camera 0 and one of 1..%d", camera, n - 1));
  const LensModel& m0 = rig.cameras[0].model;
  const bool latlon = model == RectifiedModel::kLatlon;
  const double widest_deg = latlon ? 180.0 : 150.0;
  if (az_fov_deg == 0 || el_fov_deg == 0) {
    auto fov = field_of_view_parts(m0);
    if (az_fov_deg == 0)
      az_fov_deg =
          fov.ok() && fov->horizontal_deg ? std::min(widest_deg, *fov->horizontal_deg) : 90;
    if (el_fov_deg == 0)
      el_fov_deg = fov.ok() && fov->vertical_deg ? std::min(widest_deg, *fov->vertical_deg) : 90;
  }
  if (latlon ? !(az_fov_deg > 0 && az_fov_deg <= 180 && el_fov_deg > 0 && el_fov_deg <= 180)
             : !(az_fov_deg > 0 && az_fov_deg < 170 && el_fov_deg > 0 && el_fov_deg < 170))
    return make_error("out_of_range",
                      format_printf("a %s rectification spans %s deg, not %g x %g",
                                    latlon ? "lat-lon" : "pinhole",
                                    latlon ? "(0, 180]" : "(0, 170)", az_fov_deg, el_fov_deg));
  // Camera 0 is the reference: its axes are the reference's. Camera N's centre and optical
  // axis in camera 0's frame.
  const Rt& rt = rig.cameras[camera].rt_cam_ref;
  const cv::Matx33d R_n_ref = rotation_matrix(rt);
  const cv::Vec3d centre_n = -(R_n_ref.t() * cv::Vec3d(rt[3], rt[4], rt[5]));
  StereoRectification out;
  out.camera = camera;
  out.baseline_m = cv::norm(centre_n);
  if (!(out.baseline_m > 1e-9))
    return make_error("singular", "the two cameras share one centre: no baseline to rectify");
  const cv::Vec3d right = centre_n / out.baseline_m;
  const cv::Vec3d forward_n = R_n_ref.t() * cv::Vec3d(0, 0, 1);
  const cv::Vec3d mean_forward = cv::Vec3d(0, 0, 1) + forward_n;
  cv::Vec3d forward = mean_forward - mean_forward.dot(right) * right;
  if (!(cv::norm(forward) > 1e-6))
    return make_error("singular",
                      "the cameras look along their baseline: no rectification keeps them apart");
  forward /= cv::norm(forward);
  const cv::Vec3d down = forward.cross(right);
  const cv::Matx33d R_rect_ref(right[0], right[1], right[2], down[0], down[1], down[2], forward[0],
                               forward[1], forward[2]);
  out.rt_rect_ref = rt_from(R_rect_ref, {0, 0, 0});
  out.rt_rect_other_ref = rt_from(R_rect_ref, -(R_rect_ref * centre_n));
  const double az0 =
      std::asin(std::clamp(mean_forward.dot(right) / cv::norm(mean_forward), -1.0, 1.0));
  out.az0_deg = az0 / kRadPerDeg;
  // Camera 0's focal length; the imager spans the fields around the mean view direction.
  const double f = m0.intrinsics[0];
  const double half_az = 0.5 * az_fov_deg * kRadPerDeg, half_el = 0.5 * el_fov_deg * kRadPerDeg;
  if (latlon) {
    // Even in angle: f pixels a radian both ways, the mean view direction (az0, 0) at the
    // imager's centre (mrcal-stereo's choice for LENSMODEL_LATLON).
    const int width = std::max(2, static_cast<int>(std::lround(2 * half_az * f)));
    const int height = std::max(2, static_cast<int>(std::lround(2 * half_el * f)));
    out.rectified.lensmodel = "LENSMODEL_LATLON";
    out.rectified.width_px = width;
    out.rectified.height_px = height;
    out.rectified.intrinsics = {f, f, 0.5 * (width - 1) - f * az0, 0.5 * (height - 1)};
    return out;
  }
  const int width = std::max(
      2, static_cast<int>(std::lround(f * (std::tan(half_az + az0) - std::tan(az0 - half_az)))));
  const int height = std::max(2, static_cast<int>(std::lround(2 * f * std::tan(half_el))));
  out.rectified.lensmodel = "LENSMODEL_PINHOLE";
  out.rectified.width_px = width;
  out.rectified.height_px = height;
  out.rectified.intrinsics = {f, f, -f * std::tan(az0 - half_az) - 0.5, 0.5 * (height - 1)};
  return out;
}

Result<std::vector<double>> rectified_pixels(const StereoRectification& r, const RigSolution& rig,
                                             int which, const std::vector<double>& q_px) {
  if (which != 0 && which != r.camera)
    return make_error("out_of_range",
                      format_printf("camera %d is not in the pair (0 and %d)", which, r.camera));
  const RigCamera& cam = rig.cameras[which];
  std::vector<double> directions;
  CAMLAB_ASSIGN(directions, unproject(cam.model, q_px));
  // Camera -> reference -> rectified, and the rectified model's projection.
  const cv::Matx33d R = rotation_matrix(r.rt_rect_ref) * rotation_matrix(cam.rt_cam_ref).t();
  std::vector<double> out;
  out.reserve(q_px.size());
  for (size_t i = 0; i + 3 <= directions.size(); i += 3) {
    const cv::Point2d q = rectified_pixel(
        r.rectified, R * cv::Vec3d(directions[i], directions[i + 1], directions[i + 2]));
    out.insert(out.end(), {q.x, q.y});
  }
  return out;
}

Result<EpipolarResidual> epipolar_residual(const StereoRectification& r, const RigData& data,
                                           const RigSolution& rig) {
  EpipolarResidual out;
  double sum_sq = 0;
  const auto& views0 = data.cameras[0].views;
  const auto& views1 = data.cameras[r.camera].views;
  for (size_t v = 0; v < std::min(views0.size(), views1.size()); ++v) {
    std::vector<double> q0, q1;
    for (size_t k = 0; k < views0[v].corners.size() && k < views1[v].corners.size(); ++k) {
      const auto &a = views0[v].corners[k], &b = views1[v].corners[k];
      if (!a.present || !b.present) continue;
      q0.insert(q0.end(), {a.x_px, a.y_px});
      q1.insert(q1.end(), {b.x_px, b.y_px});
    }
    if (q0.empty()) continue;
    std::vector<double> r0, r1;
    CAMLAB_ASSIGN(r0, rectified_pixels(r, rig, 0, q0));
    CAMLAB_ASSIGN(r1, rectified_pixels(r, rig, r.camera, q1));
    int used = 0;
    for (size_t i = 1; i < r0.size(); i += 2) {
      const double dy = r0[i] - r1[i];
      if (!std::isfinite(dy)) continue;
      sum_sq += dy * dy;
      out.worst_px = std::max(out.worst_px, std::abs(dy));
      ++used;
    }
    out.corners += used;
    out.views += used > 0;
  }
  if (out.corners == 0)
    return make_error("too_few_views",
                      format_printf("cameras 0 and %d share no board corner", r.camera));
  out.rms_px = std::sqrt(sum_sq / out.corners);
  return out;
}

double rectified_range_m(const StereoRectification& r, double x0_px, double y_px, double xN_px) {
  const auto& k = r.rectified.intrinsics;
  if (is_latlon(r.rectified)) {
    const double az0 = (x0_px - k[2]) / k[0], azn = (xN_px - k[2]) / k[0];
    if (!(az0 > azn)) return std::nan("");
    return r.baseline_m * std::cos(azn) / std::sin(az0 - azn);
  }
  if (!(x0_px > xN_px)) return std::nan("");
  const double z = k[0] * r.baseline_m / (x0_px - xN_px);
  return z * cv::norm(cv::Vec3d((x0_px - k[2]) / k[0], (y_px - k[3]) / k[1], 1.0));
}

Result<std::array<cv::Mat, 2>> rectification_maps(const StereoRectification& r,
                                                  const RigSolution& rig, int which) {
  if (which != 0 && which != r.camera)
    return make_error("out_of_range",
                      format_printf("camera %d is not in the pair (0 and %d)", which, r.camera));
  const int w = r.rectified.width_px, h = r.rectified.height_px;
  // Rectified pixel -> rectified ray -> the camera's ray -> its pixel.
  const cv::Matx33d R =
      rotation_matrix(rig.cameras[which].rt_cam_ref) * rotation_matrix(r.rt_rect_ref).t();
  std::vector<double> points;
  points.reserve(static_cast<size_t>(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const cv::Vec3d d = R * rectified_ray(r.rectified, x, y);
      points.insert(points.end(), {d[0], d[1], d[2]});
    }
  std::vector<double> q;
  CAMLAB_ASSIGN(q, project(rig.cameras[which].model, points));
  const std::string& lensmodel = rig.cameras[which].model.lensmodel;
  const bool sees_behind = lensmodel.find("STEREOGRAPHIC") != std::string::npos;
  std::array<cv::Mat, 2> maps{cv::Mat(h, w, CV_32F), cv::Mat(h, w, CV_32F)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      // A pinhole-like model mirrors what is behind it into its image; a stereographic
      // (or splined stereographic) fisheye sees past 90 deg off its axis.
      const bool ahead = points[3 * i + 2] > 0 || sees_behind;
      maps[0].at<float>(y, x) = ahead ? static_cast<float>(q[2 * i]) : -1.f;
      maps[1].at<float>(y, x) = ahead ? static_cast<float>(q[2 * i + 1]) : -1.f;
    }
  return maps;
}

}  // namespace camlab::calib
