// Projection uncertainty of a calibration, as mrcal defines it (mrcal 2.2,
// mrcal.projection_uncertainty; http://mrcal.secretsauce.net/uncertainty.html):
//
//   1. Observation noise. Each corner's pixel coordinates carry independent noise of
//      sigma / w (w its weight), so the weighted measurements x = w (q - q_obs) have
//      Var(x) = sigma^2 I. sigma is the detection noise: given, or estimated from the
//      inlier residuals at the optimum (sqrt(sum x^2 / (2 N_inliers - N_state))).
//   2. Through the optimum. At the optimum J^T x = 0, so a perturbation dx of the
//      observations moves the state by db = -(J^T J)^-1 J_obs^T dx, and
//        Var(b) = sigma^2 (J^T J)^-1 J_obs^T J_obs (J^T J)^-1
//      with J the Jacobian of all measurements (regularization included) and J_obs its
//      rows of board observations. J comes from mrcal_optimizer_callback on exactly the
//      problem that was solved (same weights, outliers, selections); it is in mrcal's
//      packed (unitless) state b* = D^-1 b, so Var(b) = D Var(b*) D.
//   3. To a projection. The camera is the reference frame, but that frame is itself
//      estimated from the boards: a point fixed in the world is fixed relative to the
//      boards, not to the camera. mrcal's "mean-frames" definition: the point p_cam seen
//      at pixel q at distance d is carried into every board's frame through the
//      solution's poses, back through perturbed poses, and averaged:
//        p_ref' = mean_i rt_i' (rt_i^-1 p_cam),   q' = project(p_ref', intrinsics')
//      (at infinity only the rotations act on the direction). So
//        dq/db = [dq/dintrinsics, dq/dp (1/N) d(rt_i p_i)/d rt_i for each board i]
//      and Var(q) = dq/db Var(b) dq/db^T, a 2x2 covariance in px^2. Its summary is the
//      worst-direction standard deviation sqrt(largest eigenvalue), as mrcal reports.
//
// Views the solver kept at a weight of 1e-3 (mis-observed) are left out of the mean of
// the boards: their poses are nearly unconstrained and would swamp the average.
//
// Reentrant.
#pragma once

#include <array>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/solver.h"

namespace camlab::calib {

// The solve's state covariance per unit observation noise, Var(b) / sigma^2, in full
// units, over b = [intrinsics (Nintrinsics, px and unitless), then per used view its
// rt_cam_board (r in rad, t in m)]: n = Nintrinsics + 6 Nviews, row-major n x n.
struct StateCovariance {
  int n = 0;
  std::vector<double> values;
  std::vector<char> in_reference;  // per used view: part of the mean of the boards
  double observed_sigma_px = 0;    // estimated detection noise (see the header)
  int state_count = 0;             // mrcal's Nstate (board warp included)
  // The final problem, for exporting it to mrcal's tools: the pool's weights (N views x
  // corners, < 0 = outlier or missing) and what the last stage optimised.
  std::vector<double> pool_weight;
  bool optimized_core = true, optimized_distortions = true, optimized_warp = false,
       regularized = false;
};

// A 2x2 covariance of a pixel (px^2).
struct PixelCovariance {
  double xx = 0, xy = 0, yy = 0;
  double worst_px() const;  // worst-direction standard deviation (mrcal's default)
  double rms_px() const;    // sqrt(trace / 2)
};

// Var(q) for the point seen at pixel (x_px, y_px) at `distance_m` from the camera
// (+infinity allowed). observed_sigma_px <= 0: the solution's estimate.
// Errors: "no_covariance" (the solve did not produce one: see Solution::covariance_error),
// "unproject_failed" (the model cannot unproject the pixel), "invalid_argument".
Result<PixelCovariance> projection_uncertainty(const Solution& solution, double x_px, double y_px,
                                               double distance_m, double observed_sigma_px = 0);

// The same for a point given in the camera frame (m; a direction when at_infinity):
// callers that evaluate one set of points for several solutions unproject them once.
// sigma_px <= 0: the solution's estimate. Error "no_covariance".
Result<PixelCovariance> projection_uncertainty_of_point(const Solution& solution,
                                                        const std::array<double, 3>& p_cam,
                                                        bool at_infinity, double sigma_px = 0);

// The working distance of a solution: the median distance of its boards' centres from
// the camera (m); 0 without boards.
double working_distance_m(const Solution& solution);

// The uncertainty at the imager's centre and four corners, at infinity and at the
// working distance (the median distance of the boards' centres), for the report.
struct UncertaintyPoint {
  std::string where;  // "centre", "top_left", "top_right", "bottom_left", "bottom_right"
  double x_px = 0, y_px = 0;
  std::optional<double> at_infinity_px;  // worst-direction stdev; empty: cannot unproject
  std::optional<double> at_working_distance_px;
};
struct UncertaintySummary {
  double observed_sigma_px = 0;
  double working_distance_m = 0;
  std::vector<UncertaintyPoint> points;
};
Result<UncertaintySummary> summarize_uncertainty(const Solution& solution);

// Worst-direction stdev on a grid of cols x rows pixel positions spanning the imager
// (pixel centres 0 .. W-1), row-major; NaN where the model cannot unproject.
Result<std::vector<double>> uncertainty_grid(const Solution& solution, int cols, int rows,
                                             double distance_m);

// mrcal's optimization_inputs of the final solve as JSON (keys as in mrcal 2.2's Python
// API; arrays as nested lists), so mrcal's Python tools can evaluate the same problem
// (tests compare with mrcal.projection_uncertainty). Error "no_covariance" when the
// solve kept no state.
Result<nlohmann::json> mrcal_optimization_inputs(const CalibrationData& data,
                                                 const Solution& solution);

}  // namespace camlab::calib
