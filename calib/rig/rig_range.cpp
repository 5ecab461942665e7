#include "calib/rig/rig_range.h"

#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "base/format.h"

namespace camlab::calib {

Result<std::array<double, 3>> triangulate_midpoint(const LensModel& camera0, const LensModel& other,
                                                   const Rt& rt_other_ref,
                                                   const std::array<double, 2>& q0,
                                                   const std::array<double, 2>& q_other) {
  std::vector<double> ray0, ray1;
  CAMLAB_ASSIGN(ray0, unproject(camera0, {q0[0], q0[1]}));
  CAMLAB_ASSIGN(ray1, unproject(other, {q_other[0], q_other[1]}));
  const cv::Matx33d R = rotation_matrix(rt_other_ref);
  const cv::Vec3d t(rt_other_ref[3], rt_other_ref[4], rt_other_ref[5]);
  const cv::Vec3d v(ray0[0], ray0[1], ray0[2]);
  const cv::Vec3d w = R.t() * cv::Vec3d(ray1[0], ray1[1], ray1[2]);
  const cv::Vec3d o = -(R.t() * t);  // the other camera's centre in camera 0's frame
  // s v and o + u w closest: a s - b u = v.o, b s - c u = w.o.
  const double a = v.dot(v), b = v.dot(w), c = w.dot(w), d = v.dot(o), e = w.dot(o);
  const double det = a * c - b * b;
  if (!(std::abs(det) > 1e-15))
    return make_error("projection_failed", "the two rays are parallel: no triangulation");
  const double s = (c * d - b * e) / det, u = (b * d - a * e) / det;
  const cv::Vec3d p = 0.5 * (s * v + o + u * w);
  return std::array<double, 3>{p[0], p[1], p[2]};
}

namespace {

struct RigParameters {
  std::vector<LensModel> models;
  std::vector<Rt> rt_cam_ref;
};

// The calibration's parameters in parameter_covariance's order, and back.
std::vector<double> parameter_vector(const RigParameters& p) {
  std::vector<double> x;
  for (const auto& m : p.models) x.insert(x.end(), m.intrinsics.begin(), m.intrinsics.end());
  for (size_t c = 1; c < p.rt_cam_ref.size(); ++c)
    x.insert(x.end(), p.rt_cam_ref[c].begin(), p.rt_cam_ref[c].end());
  return x;
}

RigParameters parameters_from(const RigParameters& shape, const std::vector<double>& x) {
  RigParameters p = shape;
  size_t k = 0;
  for (auto& m : p.models)
    for (double& v : m.intrinsics) v = x[k++];
  for (size_t c = 1; c < p.rt_cam_ref.size(); ++c)
    for (double& v : p.rt_cam_ref[c]) v = x[k++];
  return p;
}

}  // namespace

Result<RangeUncertainty> triangulated_range_uncertainty(const RigSolution& solution, int camera,
                                                        double range_m) {
  const int n = static_cast<int>(solution.cameras.size());
  if (camera < 1 || camera >= n)
    return make_error("out_of_range",
                      format_printf("camera %d: the other camera is one of 1..%d", camera, n - 1));
  if (!(range_m > 0 && range_m <= 1e5))
    return make_error("out_of_range",
                      format_printf("range %g m: a range is in (0, 100000] m", range_m));
  RigParameters base;
  for (const auto& cam : solution.cameras) {
    base.models.push_back(cam.model);
    base.rt_cam_ref.push_back(cam.rt_cam_ref);
  }
  const std::vector<double> x0 = parameter_vector(base);
  const size_t k = x0.size();
  if (static_cast<int>(k) != solution.parameter_count ||
      solution.parameter_covariance.size() != k * k)
    return make_error("no_covariance", "the rig solution carries no parameter covariance");

  // The point on camera 0's axis (the ray of its principal point) and its two pixels.
  const LensModel& m0 = base.models[0];
  std::vector<double> axis;
  CAMLAB_ASSIGN(axis, unproject(m0, {m0.intrinsics[2], m0.intrinsics[3]}));
  const cv::Vec3d p0 = cv::Vec3d(axis[0], axis[1], axis[2]) * range_m;
  const Rt& rt = base.rt_cam_ref[camera];
  const cv::Matx33d R = rotation_matrix(rt);
  const cv::Vec3d p1 = R * p0 + cv::Vec3d(rt[3], rt[4], rt[5]);
  std::vector<double> q0, q1;
  CAMLAB_ASSIGN(q0, project(m0, {p0[0], p0[1], p0[2]}));
  CAMLAB_ASSIGN(q1, project(base.models[camera], {p1[0], p1[1], p1[2]}));
  const LensModel& other = base.models[camera];
  if (!(p1[2] > 0 && q1[0] >= 0 && q1[1] >= 0 && q1[0] <= other.width_px - 1 &&
        q1[1] <= other.height_px - 1))
    return make_error("out_of_range",
                      format_printf("a point %g m along camera 0's axis is outside camera %d's "
                                    "view",
                                    range_m, camera));
  RangeUncertainty out;
  out.range_m = range_m;
  out.pixel_camera0 = {q0[0], q0[1]};
  out.pixel_other = {q1[0], q1[1]};
  auto range_at = [&](const std::vector<double>& x) -> Result<double> {
    const RigParameters p = parameters_from(base, x);
    std::array<double, 3> point{};
    CAMLAB_ASSIGN(point, triangulate_midpoint(p.models[0], p.models[camera], p.rt_cam_ref[camera],
                                              out.pixel_camera0, out.pixel_other));
    return std::sqrt(point[0] * point[0] + point[1] * point[1] + point[2] * point[2]);
  };
  CAMLAB_ASSIGN(out.triangulated_range_m, range_at(x0));
  // The gradient by central differences; parameters of cameras other than 0 and `camera`
  // do not move the point, and are skipped.
  const size_t nparams = base.models[0].intrinsics.size();
  std::vector<double> gradient(k, 0.0);
  for (size_t j = 0; j < k; ++j) {
    const bool intrinsic = j < nparams * n;
    const size_t owner = intrinsic ? j / nparams : 1 + (j - nparams * n) / 6;
    if (owner != 0 && owner != static_cast<size_t>(camera)) continue;
    const double h = 1e-6 * std::max(1.0, std::abs(x0[j]));
    std::vector<double> plus = x0, minus = x0;
    plus[j] += h;
    minus[j] -= h;
    double r_plus = 0, r_minus = 0;
    CAMLAB_ASSIGN(r_plus, range_at(plus));
    CAMLAB_ASSIGN(r_minus, range_at(minus));
    gradient[j] = (r_plus - r_minus) / (2 * h);
  }
  // part: which parameters' block of the covariance (all, intrinsics, extrinsics).
  enum class Part { kAll, kIntrinsics, kExtrinsics };
  auto variance = [&](Part part) {
    auto in = [&](size_t j) {
      const bool intrinsic = j < nparams * n;
      return part == Part::kAll || (part == Part::kIntrinsics) == intrinsic;
    };
    double v = 0;
    for (size_t a = 0; a < k; ++a)
      for (size_t b = 0; b < k; ++b)
        if (in(a) && in(b))
          v += gradient[a] * solution.parameter_covariance[a * k + b] * gradient[b];
    return std::max(0.0, v);
  };
  out.sigma_mm = std::sqrt(variance(Part::kAll)) * 1000;
  out.sigma_intrinsics_alone_mm = std::sqrt(variance(Part::kIntrinsics)) * 1000;
  out.sigma_extrinsics_alone_mm = std::sqrt(variance(Part::kExtrinsics)) * 1000;
  return out;
}

}  // namespace camlab::calib
