#include "calib/intrinsics_uncertainty.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "calib/lens_model.h"
#include "calib/uncertainty.h"

namespace camlab::calib {

namespace {

// The three FOVs of `model` (NaN where undefined).
std::array<double, 3> fovs(const LensModel& model) {
  std::array<double, 3> out{NAN, NAN, NAN};
  auto f = field_of_view_parts(model);
  if (!f) return out;
  if (f->horizontal_deg) out[0] = *f->horizontal_deg;
  if (f->vertical_deg) out[1] = *f->vertical_deg;
  if (f->diagonal_deg) out[2] = *f->diagonal_deg;
  return out;
}

}  // namespace

Result<IntrinsicsUncertainty> intrinsics_uncertainty(const Solution& solution) {
  if (!solution.covariance)
    return make_error("no_covariance", "no state covariance: " + (solution.covariance_error.empty()
                                                                      ? std::string("not computed")
                                                                      : solution.covariance_error));
  const StateCovariance& cov = *solution.covariance;
  const LensModel& model = solution.model;
  const int k = static_cast<int>(model.intrinsics.size());
  if (k < 4 || cov.n < k || cov.values.size() != static_cast<size_t>(cov.n) * cov.n)
    return make_error("no_covariance", "the state covariance does not cover the intrinsics");
  const double sigma2 = cov.observed_sigma_px * cov.observed_sigma_px;
  auto c = [&](int i, int j) { return sigma2 * cov.values[static_cast<size_t>(i) * cov.n + j]; };
  IntrinsicsUncertainty out;
  out.fx_px = std::sqrt(std::max(0.0, c(0, 0)));
  out.fy_px = std::sqrt(std::max(0.0, c(1, 1)));
  out.cx_px = std::sqrt(std::max(0.0, c(2, 2)));
  out.cy_px = std::sqrt(std::max(0.0, c(3, 3)));
  // Each FOV's gradient over the intrinsics by central differences: a step of 1e-6 of
  // each parameter's scale (1 for the unitless distortions and knots) keeps the
  // truncation error far under the noise and the rounding error under 1e-8 deg.
  const std::array<double, 3> at = fovs(model);
  std::array<std::vector<double>, 3> gradient;
  for (auto& g : gradient) g.assign(k, 0.0);
  LensModel moved = model;
  for (int i = 0; i < k; ++i) {
    const double h = 1e-6 * std::max(1.0, std::fabs(model.intrinsics[i]));
    moved.intrinsics[i] = model.intrinsics[i] + h;
    const auto up = fovs(moved);
    moved.intrinsics[i] = model.intrinsics[i] - h;
    const auto down = fovs(moved);
    moved.intrinsics[i] = model.intrinsics[i];
    for (int f = 0; f < 3; ++f) gradient[f][i] = (up[f] - down[f]) / (2 * h);
  }
  std::array<std::optional<double>*, 3> outs = {&out.horizontal_fov_deg, &out.vertical_fov_deg,
                                                &out.diagonal_fov_deg};
  for (int f = 0; f < 3; ++f) {
    if (!std::isfinite(at[f])) continue;
    const std::vector<double>& g = gradient[f];
    if (!std::all_of(g.begin(), g.end(), [](double v) { return std::isfinite(v); })) continue;
    double var = 0;
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) var += g[i] * c(i, j) * g[j];
    *outs[f] = std::sqrt(std::max(0.0, var));
  }
  return out;
}

}  // namespace camlab::calib
