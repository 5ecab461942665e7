#include "calib/lens_model.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "calib/mrcal_api.h"

namespace camlab::calib {

namespace {

// A splined model's size within the limits of lens_model.h: its knots set the solve's
// state size, and mrcal keeps per-parameter arrays on the stack, so an unbounded grid is a
// crash (2000 x 2000 knots) or minutes of solve (60 x 45) rather than a better fit.
Status check_spline_limits(const std::string& name, const mrcal_lensmodel_t& m) {
  const auto& c = m.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
  // mrcal reads each number into 16 bits, so Nx=65540 would read as 4: a name that does
  // not come back unchanged from mrcal's own spelling was not read as written.
  char canonical[256];
  if (!mrcal_lensmodel_name(canonical, sizeof canonical, &m) || name != canonical)
    return make_error("bad_lensmodel",
                      "the splined model '" + name.substr(0, 120) +
                          "' is not in mrcal's form LENSMODEL_SPLINED_STEREOGRAPHIC"
                          "_order=3_Nx=16_Ny=10_fov_x_deg=120 (decimal "
                          "integers, no leading zeros)");
  if (c.order < kSplineOrderMin || c.order > kSplineOrderMax)
    return make_error("out_of_range", "the spline's order = " + std::to_string(c.order) +
                                          " is outside [" + std::to_string(kSplineOrderMin) + ", " +
                                          std::to_string(kSplineOrderMax) + "]");
  if (c.Nx < kSplineKnotsMin || c.Nx > kSplineKnotsMax || c.Ny < kSplineKnotsMin ||
      c.Ny > kSplineKnotsMax || c.Nx * c.Ny > kSplineKnotsTotalMax)
    return make_error("out_of_range",
                      "the spline's grid Nx x Ny = " + std::to_string(c.Nx) + " x " +
                          std::to_string(c.Ny) + " is outside the limits: each in [" +
                          std::to_string(kSplineKnotsMin) + ", " + std::to_string(kSplineKnotsMax) +
                          "] knots and at most " + std::to_string(kSplineKnotsTotalMax) +
                          " knots in all (mrcal's fisheye examples use 30 x 20)");
  if (c.fov_x_deg < kSplineFovXDegMin || c.fov_x_deg > kSplineFovXDegMax)
    return make_error("out_of_range", "the spline's fov_x_deg = " + std::to_string(c.fov_x_deg) +
                                          " is outside [" + std::to_string(kSplineFovXDegMin) +
                                          ", " + std::to_string(kSplineFovXDegMax) + "] degrees");
  return {};
}

Result<mrcal_lensmodel_t> parse_model(const std::string& name) {
  if (name.size() > kLensmodelNameMaxChars)
    return make_error("bad_lensmodel", "a lens model name has at most " +
                                           std::to_string(kLensmodelNameMaxChars) + " characters");
  mrcal_lensmodel_t m;
  if (!mrcal_lensmodel_from_name(&m, name.c_str()) || m.type < 0)
    return make_error("bad_lensmodel",
                      "unknown or unconfigured mrcal lens model '" + name.substr(0, 120) + "'");
  if (m.type == MRCAL_LENSMODEL_CAHVORE || !mrcal_lensmodel_metadata(&m).has_core)
    return make_error("bad_lensmodel",
                      "lens model '" + name + "' is not supported (no intrinsics core)");
  if (m.type == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC)
    if (Status s = check_spline_limits(name, m); !s) return s.error();
  return m;
}

double angle_between(const double* a, const double* b) {
  const double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2],
               cz = a[0] * b[1] - a[1] * b[0];
  const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot);
}

// The field between two image points' directions a and b, seen from the camera: the
// angle between them while both look forward (z > 0); beyond, where a fisheye sees
// behind its own plane, the sum of their angles off the optical axis, so a field past
// 180 deg reads as such (the angle between two directions folds back under 180). The two
// agree at 90 deg each side for edge points opposite across the axis.
double field_between(const double* a, const double* b) {
  if (a[2] > 0 && b[2] > 0) return angle_between(a, b);
  auto off_axis = [](const double* v) { return std::atan2(std::hypot(v[0], v[1]), v[2]); };
  return off_axis(a) + off_axis(b);
}

}  // namespace

Result<int> lensmodel_param_count(const std::string& lensmodel) {
  mrcal_lensmodel_t m;
  CAMLAB_ASSIGN(m, parse_model(lensmodel));
  return mrcal_lensmodel_num_params(&m);
}

Result<std::string> configured_lensmodel(const std::string& name_in, int width_px, int height_px,
                                         double fov_x_deg_hint) {
  std::string name = name_in;
  if (name.rfind("LENSMODEL_", 0) != 0) name = "LENSMODEL_" + name;
  if (name == "LENSMODEL_SPLINED_STEREOGRAPHIC") {
    if (width_px <= 0 || height_px <= 0)
      return make_error("invalid_argument", "a splined model needs the imager size");
    const int nx = 16;
    const int ny = std::clamp(static_cast<int>(std::lround(nx * double(height_px) / width_px)),
                              kSplineKnotsMin, kSplineKnotsMax);
    // The spline must span the whole field of view with some margin (a fisheye's corners
    // see further off-axis than its sides: 1.25 x the horizontal field); mrcal requires
    // an integer number of degrees; at most 280, inside the limit of 300.
    const int fov = std::clamp(static_cast<int>(std::ceil(fov_x_deg_hint * 1.1 + 5)), 10, 280);
    name += "_order=3_Nx=" + std::to_string(nx) + "_Ny=" + std::to_string(ny) +
            "_fov_x_deg=" + std::to_string(fov);
  }
  if (auto m = parse_model(name); !m) return m.error();
  return name;
}

Result<std::vector<double>> project(const LensModel& model, const std::vector<double>& p_cam) {
  mrcal_lensmodel_t m;
  CAMLAB_ASSIGN(m, parse_model(model.lensmodel));
  if (static_cast<int>(model.intrinsics.size()) != mrcal_lensmodel_num_params(&m))
    return make_error("bad_lensmodel", "intrinsics length does not match " + model.lensmodel);
  const int n = static_cast<int>(p_cam.size() / 3);
  std::vector<double> q(2 * n);
  if (n > 0 && !mrcal_project(reinterpret_cast<mrcal_point2_t*>(q.data()), nullptr, nullptr,
                              reinterpret_cast<const mrcal_point3_t*>(p_cam.data()), n, &m,
                              model.intrinsics.data()))
    return make_error("projection_failed", "mrcal_project failed for " + model.lensmodel);
  for (double v : q)
    if (!std::isfinite(v)) return make_error("projection_failed", "projection is not finite");
  return q;
}

Result<std::vector<double>> unproject(const LensModel& model, const std::vector<double>& q_px) {
  mrcal_lensmodel_t m;
  CAMLAB_ASSIGN(m, parse_model(model.lensmodel));
  if (static_cast<int>(model.intrinsics.size()) != mrcal_lensmodel_num_params(&m))
    return make_error("bad_lensmodel", "intrinsics length does not match " + model.lensmodel);
  const int n = static_cast<int>(q_px.size() / 2);
  std::vector<double> v(3 * n);
  if (n > 0 && !mrcal_unproject(reinterpret_cast<mrcal_point3_t*>(v.data()),
                                reinterpret_cast<const mrcal_point2_t*>(q_px.data()), n, &m,
                                model.intrinsics.data()))
    return make_error("projection_failed", "mrcal_unproject failed for " + model.lensmodel);
  for (int i = 0; i < n; ++i) {
    double* p = &v[3 * i];
    const double norm = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    if (!std::isfinite(norm) || norm <= 0)
      return make_error("projection_failed", "the model does not unproject pixel (" +
                                                 std::to_string(q_px[2 * i]) + ", " +
                                                 std::to_string(q_px[2 * i + 1]) + ")");
    for (int k = 0; k < 3; ++k) p[k] /= norm;
  }
  return v;
}

Result<std::vector<double>> unproject_each(const LensModel& model, const std::vector<double>& q_px,
                                           std::vector<char>* valid) {
  mrcal_lensmodel_t m;
  CAMLAB_ASSIGN(m, parse_model(model.lensmodel));
  if (static_cast<int>(model.intrinsics.size()) != mrcal_lensmodel_num_params(&m))
    return make_error("bad_lensmodel", "intrinsics length does not match " + model.lensmodel);
  const int n = static_cast<int>(q_px.size() / 2);
  std::vector<double> v(3 * n, 0.0);
  valid->assign(n, 0);
  // Try all at once (fast path); on failure one by one.
  if (mrcal_unproject(reinterpret_cast<mrcal_point3_t*>(v.data()),
                      reinterpret_cast<const mrcal_point2_t*>(q_px.data()), n, &m,
                      model.intrinsics.data())) {
    bool all = true;
    for (double x : v) all &= std::isfinite(x);
    if (!all) v.assign(3 * n, NAN);
  } else {
    v.assign(3 * n, NAN);
  }
  for (int i = 0; i < n; ++i) {
    double* p = &v[3 * i];
    if (!std::isfinite(p[0] + p[1] + p[2]) &&
        !mrcal_unproject(reinterpret_cast<mrcal_point3_t*>(p),
                         reinterpret_cast<const mrcal_point2_t*>(&q_px[2 * i]), 1, &m,
                         model.intrinsics.data()))
      p[0] = NAN;
    const double norm = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    if (!std::isfinite(norm) || norm <= 0) {
      p[0] = p[1] = p[2] = 0;
      continue;
    }
    for (int k = 0; k < 3; ++k) p[k] /= norm;
    (*valid)[i] = 1;
  }
  return v;
}

Result<FieldOfView> field_of_view(const LensModel& model) {
  const double w = model.width_px, h = model.height_px;
  const double xm = (w - 1) / 2, ym = (h - 1) / 2;
  const std::vector<double> q = {-0.5, ym,   w - 0.5, ym,      xm,      -0.5, xm,   h - 0.5,
                                 -0.5, -0.5, w - 0.5, h - 0.5, w - 0.5, -0.5, -0.5, h - 0.5};
  std::vector<double> v;
  CAMLAB_ASSIGN(v, unproject(model, q));
  // A model that folds over returns directions that do not reproject to the edges.
  std::vector<double> back;
  CAMLAB_ASSIGN(back, project(model, v));
  for (size_t i = 0; i < q.size(); ++i)
    if (std::fabs(back[i] - q[i]) > 0.01)
      return make_error("projection_failed",
                        "the fitted model does not invert at the image edges; its FOV is undefined "
                        "(the model extrapolates beyond the data)");
  FieldOfView fov;
  constexpr double kDeg = 180.0 / M_PI;
  fov.horizontal_deg = field_between(&v[0], &v[3]) * kDeg;
  fov.vertical_deg = field_between(&v[6], &v[9]) * kDeg;
  fov.diagonal_deg = 0.5 * (field_between(&v[12], &v[15]) + field_between(&v[18], &v[21])) * kDeg;
  return fov;
}

Result<FieldOfViewParts> field_of_view_parts(const LensModel& model) {
  const double w = model.width_px, h = model.height_px;
  const double xm = (w - 1) / 2, ym = (h - 1) / 2;
  const std::vector<double> q = {-0.5, ym,   w - 0.5, ym,      xm,      -0.5, xm,   h - 0.5,
                                 -0.5, -0.5, w - 0.5, h - 0.5, w - 0.5, -0.5, -0.5, h - 0.5};
  std::vector<char> valid;
  std::vector<double> v;
  CAMLAB_ASSIGN(v, unproject_each(model, q, &valid));
  // A point counts when its direction projects back onto it: a model that folds over
  // returns directions that land elsewhere.
  for (int i = 0; i < 8; ++i) {
    if (!valid[i]) continue;
    auto back = project(model, {v[3 * i], v[3 * i + 1], v[3 * i + 2]});
    valid[i] = back.ok() && std::fabs((*back)[0] - q[2 * i]) <= 0.01 &&
               std::fabs((*back)[1] - q[2 * i + 1]) <= 0.01;
  }
  constexpr double kDeg = 180.0 / M_PI;
  FieldOfViewParts fov;
  if (valid[0] && valid[1]) fov.horizontal_deg = field_between(&v[0], &v[3]) * kDeg;
  if (valid[2] && valid[3]) fov.vertical_deg = field_between(&v[6], &v[9]) * kDeg;
  if (valid[4] && valid[5] && valid[6] && valid[7])
    fov.diagonal_deg = 0.5 * (field_between(&v[12], &v[15]) + field_between(&v[18], &v[21])) * kDeg;
  return fov;
}

namespace {

// Rotates unit vectors v (3 per point) by the rotation vector r (Rodrigues).
std::vector<double> rotate(const std::vector<double>& v, const double r[3]) {
  const double th = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  if (th < 1e-300) return v;
  const double k[3] = {r[0] / th, r[1] / th, r[2] / th};
  const double c = std::cos(th), s = std::sin(th);
  std::vector<double> out(v.size());
  for (size_t i = 0; i < v.size(); i += 3) {
    const double* p = &v[i];
    const double dot = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
    const double cr[3] = {k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2],
                          k[0] * p[1] - k[1] * p[0]};
    for (int j = 0; j < 3; ++j) out[i + j] = p[j] * c + cr[j] * s + k[j] * dot * (1 - c);
  }
  return out;
}

}  // namespace

Result<ProjectionDifference> projection_difference(const LensModel& a, const LensModel& b,
                                                   double fraction, int grid, bool fit_rotation) {
  std::vector<double> q;
  const double w = a.width_px, h = a.height_px;
  for (int j = 0; j < grid; ++j)
    for (int i = 0; i < grid; ++i) {
      const double u = (i + 0.5) / grid, v = (j + 0.5) / grid;
      q.push_back((0.5 + (u - 0.5) * fraction) * w - 0.5);
      q.push_back((0.5 + (v - 0.5) * fraction) * h - 0.5);
    }
  std::vector<double> dirs;
  CAMLAB_ASSIGN(dirs, unproject(a, q));
  const size_t n = q.size();
  double r[3] = {0, 0, 0};
  if (fit_rotation) {
    // Gauss-Newton on the rotation vector with a numerical Jacobian: 3 unknowns, a few
    // iterations from zero (the rotation is small).
    for (int it = 0; it < 6; ++it) {
      std::vector<double> e0;
      CAMLAB_ASSIGN(e0, project(b, rotate(dirs, r)));
      for (size_t i = 0; i < n; ++i) e0[i] -= q[i];
      std::vector<double> J(n * 3);
      const double step = 1e-7;
      for (int k = 0; k < 3; ++k) {
        double rk[3] = {r[0], r[1], r[2]};
        rk[k] += step;
        std::vector<double> e;
        CAMLAB_ASSIGN(e, project(b, rotate(dirs, rk)));
        for (size_t i = 0; i < n; ++i) J[i * 3 + k] = (e[i] - q[i] - e0[i]) / step;
      }
      double A[3][3] = {}, g[3] = {};
      for (size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
          g[k] += J[i * 3 + k] * e0[i];
          for (int l = 0; l < 3; ++l) A[k][l] += J[i * 3 + k] * J[i * 3 + l];
        }
      // Solve A d = -g by Cramer's rule (3 x 3, well conditioned for a full grid).
      const double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                         A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                         A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
      if (!(std::fabs(det) > 0)) break;
      double d[3];
      for (int k = 0; k < 3; ++k) {
        double M[3][3];
        for (int x = 0; x < 3; ++x)
          for (int y = 0; y < 3; ++y) M[x][y] = y == k ? -g[x] : A[x][y];
        d[k] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) /
               det;
      }
      for (int k = 0; k < 3; ++k) r[k] += d[k];
      if (std::fabs(d[0]) + std::fabs(d[1]) + std::fabs(d[2]) < 1e-12) break;
    }
  }
  std::vector<double> qb;
  CAMLAB_ASSIGN(qb, project(b, rotate(dirs, r)));
  ProjectionDifference d;
  double sum = 0;
  for (size_t i = 0; i < q.size() / 2; ++i) {
    const double e = std::hypot(qb[2 * i] - q[2 * i], qb[2 * i + 1] - q[2 * i + 1]);
    sum += e * e;
    d.max_px = std::max(d.max_px, e);
  }
  d.samples = static_cast<int>(q.size() / 2);
  d.rms_px = std::sqrt(sum / std::max(1, d.samples));
  return d;
}

}  // namespace camlab::calib
