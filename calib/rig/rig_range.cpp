#include "calib/rig/rig_range.h"

#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "base/format.h"

namespace camlab::calib {

namespace {

// Where the rays of q0 (camera 0) and q_other meet: their parameters along themselves (s
// on camera 0's ray, u on the other's), the distance between their closest points, and
// the midpoint of those.
struct RayMeeting {
  double s = 0, u = 0, miss_m = 0;
  std::array<double, 3> midpoint{};  // in camera 0's frame
};

Result<RayMeeting> ray_meeting(const LensModel& camera0, const LensModel& other,
                               const Rt& rt_other_ref, const std::array<double, 2>& q0,
                               const std::array<double, 2>& q_other) {
  std::vector<double> ray0, ray1;
  CAMLAB_ASSIGN(ray0, unproject(camera0, {q0[0], q0[1]}));
  CAMLAB_ASSIGN(ray1, unproject(other, {q_other[0], q_other[1]}));
  const cv::Matx33d R = rotation_matrix(rt_other_ref);
  const cv::Vec3d t(rt_other_ref[3], rt_other_ref[4], rt_other_ref[5]);
  const cv::Vec3d v(ray0[0], ray0[1], ray0[2]);
  const cv::Vec3d w = R.t() * cv::Vec3d(ray1[0], ray1[1], ray1[2]);
  const cv::Vec3d o = -(R.t() * t);
  const double a = v.dot(v), b = v.dot(w), c = w.dot(w), d = v.dot(o), e = w.dot(o);
  const double det = a * c - b * b;
  if (!(std::abs(det) > 1e-15))
    return make_error("projection_failed", "the two rays are parallel: no triangulation");
  RayMeeting m;
  m.s = (c * d - b * e) / det;
  m.u = (b * d - a * e) / det;
  m.miss_m = cv::norm(m.s * v - (o + m.u * w));
  const cv::Vec3d p = 0.5 * (m.s * v + o + m.u * w);
  m.midpoint = {p[0], p[1], p[2]};
  return m;
}

}  // namespace

Result<std::array<double, 3>> triangulate_midpoint(const LensModel& camera0, const LensModel& other,
                                                   const Rt& rt_other_ref,
                                                   const std::array<double, 2>& q0,
                                                   const std::array<double, 2>& q_other) {
  RayMeeting m;
  CAMLAB_ASSIGN(m, ray_meeting(camera0, other, rt_other_ref, q0, q_other));
  return m.midpoint;
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

// The rig's lenses and poses in parameter_covariance's order, after checking that `camera`
// is one of the rig's other cameras.
Result<RigParameters> pair_parameters(const RigSolution& solution, int camera) {
  const int n = static_cast<int>(solution.cameras.size());
  if (camera < 1 || camera >= n)
    return make_error("out_of_range",
                      format_printf("camera %d: the other camera is one of 1..%d", camera, n - 1));
  RigParameters base;
  for (const auto& cam : solution.cameras) {
    base.models.push_back(cam.model);
    base.rt_cam_ref.push_back(cam.rt_cam_ref);
  }
  return base;
}

// The point's (x, y, z) and range from camera 0.
using PointAndRange = std::array<double, 4>;
PointAndRange point_and_range(const std::array<double, 3>& p) {
  return {p[0], p[1], p[2], std::hypot(p[0], p[1], p[2])};
}

// The gradient of the point triangulated from q0 and q_other, and of its range, against each
// calibration parameter (parameter_covariance's order), by central differences; zero for the
// parameters of cameras other than 0 and `camera`, which do not move it.
Result<std::vector<PointAndRange>> parameter_gradient(const RigParameters& base, int camera,
                                                      const std::array<double, 2>& q0,
                                                      const std::array<double, 2>& q_other) {
  const std::vector<double> x0 = parameter_vector(base);
  const size_t k = x0.size(), n = base.models.size();
  const size_t nparams = base.models[0].intrinsics.size();
  std::vector<PointAndRange> gradient(k, PointAndRange{});
  auto at = [&](const std::vector<double>& x) -> Result<PointAndRange> {
    const RigParameters p = parameters_from(base, x);
    std::array<double, 3> point{};
    CAMLAB_ASSIGN(point, triangulate_midpoint(p.models[0], p.models[camera], p.rt_cam_ref[camera],
                                              q0, q_other));
    return point_and_range(point);
  };
  for (size_t j = 0; j < k; ++j) {
    const bool intrinsic = j < nparams * n;
    const size_t owner = intrinsic ? j / nparams : 1 + (j - nparams * n) / 6;
    if (owner != 0 && owner != static_cast<size_t>(camera)) continue;
    const double h = 1e-6 * std::max(1.0, std::abs(x0[j]));
    std::vector<double> plus = x0, minus = x0;
    plus[j] += h;
    minus[j] -= h;
    PointAndRange a{}, b{};
    CAMLAB_ASSIGN(a, at(plus));
    CAMLAB_ASSIGN(b, at(minus));
    for (int r = 0; r < 4; ++r) gradient[j][r] = (a[r] - b[r]) / (2 * h);
  }
  return gradient;
}

}  // namespace

Result<RangeUncertainty> triangulated_range_uncertainty(const RigSolution& solution, int camera,
                                                        double range_m) {
  const int n = static_cast<int>(solution.cameras.size());
  RigParameters base;
  CAMLAB_ASSIGN(base, pair_parameters(solution, camera));
  if (!(range_m > 0 && range_m <= 1e5))
    return make_error("out_of_range",
                      format_printf("range %g m: a range is in (0, 100000] m", range_m));
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
  std::array<double, 3> point{};
  CAMLAB_ASSIGN(point, triangulate_midpoint(m0, other, rt, out.pixel_camera0, out.pixel_other));
  out.triangulated_range_m = std::hypot(point[0], point[1], point[2]);
  std::vector<PointAndRange> point_gradient;
  CAMLAB_ASSIGN(point_gradient,
                parameter_gradient(base, camera, out.pixel_camera0, out.pixel_other));
  const size_t nparams = m0.intrinsics.size();
  std::vector<double> gradient(k, 0.0);
  for (size_t j = 0; j < k; ++j) gradient[j] = point_gradient[j][3];
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

namespace camlab::calib {

Result<TriangulatedPoint> triangulate_point(const RigSolution& solution, int camera,
                                            const std::array<double, 2>& q0,
                                            const std::array<double, 2>& q_other,
                                            double pixel_sigma_px) {
  RigParameters base;
  CAMLAB_ASSIGN(base, pair_parameters(solution, camera));
  if (!(pixel_sigma_px >= 0 && pixel_sigma_px < 1e3))
    return make_error("out_of_range",
                      format_printf("pixel sigma %g px: it is in [0, 1000) px", pixel_sigma_px));
  const LensModel& m0 = base.models[0];
  const LensModel& other = base.models[camera];
  const Rt& rt = base.rt_cam_ref[camera];
  RayMeeting meeting;
  CAMLAB_ASSIGN(meeting, ray_meeting(m0, other, rt, q0, q_other));
  if (!(meeting.s > 0 && meeting.u > 0))
    return make_error("projection_failed",
                      format_printf("the rays of (%.2f, %.2f) and (%.2f, %.2f) meet behind a "
                                    "camera: not one point, or not this rig",
                                    q0[0], q0[1], q_other[0], q_other[1]));
  TriangulatedPoint out;
  out.point_m = meeting.midpoint;
  out.range_m = std::hypot(out.point_m[0], out.point_m[1], out.point_m[2]);
  out.miss_mm = meeting.miss_m * 1000;

  // Gradients by central differences of (x, y, z, range) against each input; the
  // variances of the four (m^2) from the inputs' covariance, g^T C g each.
  PointAndRange variance{};
  auto add_term = [&](const std::vector<PointAndRange>& gradient, const std::vector<double>& cov) {
    const size_t k = gradient.size();
    for (int r = 0; r < 4; ++r) {
      double v = 0;
      for (size_t a = 0; a < k; ++a)
        for (size_t b = 0; b < k; ++b) v += gradient[a][r] * cov[a * k + b] * gradient[b][r];
      variance[r] += v;
    }
  };
  // The pixels: independent, pixel_sigma_px per coordinate.
  std::vector<PointAndRange> pixel_gradient(4);
  for (int j = 0; j < 4; ++j) {
    const double h = 1e-3;
    std::array<double, 2> a0 = q0, a1 = q_other, b0 = q0, b1 = q_other;
    (j < 2 ? a0 : a1)[j % 2] += h;
    (j < 2 ? b0 : b1)[j % 2] -= h;
    std::array<double, 3> plus{}, minus{};
    CAMLAB_ASSIGN(plus, triangulate_midpoint(m0, other, rt, a0, a1));
    CAMLAB_ASSIGN(minus, triangulate_midpoint(m0, other, rt, b0, b1));
    const PointAndRange vp = point_and_range(plus), vm = point_and_range(minus);
    for (int r = 0; r < 4; ++r) pixel_gradient[j][r] = (vp[r] - vm[r]) / (2 * h);
  }
  std::vector<double> pixel_covariance(16, 0.0);
  for (int j = 0; j < 4; ++j) pixel_covariance[5 * j] = pixel_sigma_px * pixel_sigma_px;
  add_term(pixel_gradient, pixel_covariance);
  out.range_sigma_pixels_mm = std::sqrt(std::max(0.0, variance[3])) * 1000;

  // The calibration: camera 0's and this camera's parameters (the others do not move it).
  const std::vector<double> x0 = parameter_vector(base);
  const size_t k = x0.size();
  if (static_cast<int>(k) == solution.parameter_count &&
      solution.parameter_covariance.size() == k * k) {
    std::vector<PointAndRange> gradient;
    CAMLAB_ASSIGN(gradient, parameter_gradient(base, camera, q0, q_other));
    const double before = variance[3];
    add_term(gradient, solution.parameter_covariance);
    out.range_sigma_calibration_mm = std::sqrt(std::max(0.0, variance[3] - before)) * 1000;
  }
  out.range_sigma_mm = std::sqrt(std::max(0.0, variance[3])) * 1000;
  for (int r = 0; r < 3; ++r) out.point_sigma_mm[r] = std::sqrt(std::max(0.0, variance[r])) * 1000;
  return out;
}

}  // namespace camlab::calib
