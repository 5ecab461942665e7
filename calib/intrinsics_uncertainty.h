// The noise-driven 1-sigma of the numbers a calibration is for: fx, fy, cx, cy and the
// three fields of view, from the solve's state covariance (uncertainty.h: Var(b) =
// sigma^2 (J^T J)^-1 J_obs^T J_obs (J^T J)^-1, sigma the estimated corner noise), the
// intrinsics' block propagated to each FOV through its gradient by central differences
// (field_of_view_parts, lens_model.h).
//
// Like the projection uncertainty, it says how far the corner noise alone moves these
// numbers with these views; a model that cannot describe the lens, a bent board or biased
// corners add error it does not see (the repeatability check, repeatability.h, sees some).
//
// Reentrant.
#pragma once

#include <optional>

#include "base/result.h"
#include "calib/solver.h"

namespace camlab::calib {

struct IntrinsicsUncertainty {
  double fx_px = 0, fy_px = 0, cx_px = 0, cy_px = 0;  // 1 sigma
  // 1 sigma, deg; empty where that FOV is undefined.
  std::optional<double> horizontal_fov_deg, vertical_fov_deg, diagonal_fov_deg;
};

// Error "no_covariance" when the solve kept none (Solution::covariance_error says why).
Result<IntrinsicsUncertainty> intrinsics_uncertainty(const Solution& solution);

}  // namespace camlab::calib
