// The projection uncertainty a solved calibration would have with one more view, without
// re-solving (internal to calib/; the next-view suggestion's scoring, view_suggestion.h).
//
// Same definition as uncertainty.h, evaluated for many candidate views cheaply:
//   - J^T J and J_obs^T J_obs of the solved problem come once from mrcal's callback
//     (packed_information). A candidate view adds only its own rows, which touch the
//     intrinsics, the board warp and its own new pose: they come from mrcal's callback on
//     the one-view problem at the same intrinsics and warp, mapped into the solved
//     problem's packed state. (mrcal scales its regularization by the number of board
//     measurements; the solved problem's regularization rows are kept as they are, which
//     the test bounds at well under 1% of the result.)
//   - The mean-frames projection needs Var(b) only through intrinsics and the reference
//     frame's small motion: the mean over boards of d(rt_i p_i) is an affine function of
//     the point, dT + Omega x p (each board's derivative is that of a rigid motion). So
//     Var(q) = sigma^2 g Var(z) g^T with z = [intrinsics, Omega, dT] and
//     g = [dq/dintrinsics, dq/dp (-[p]_x), dq/dp]; Var(z) = L Var(b) L^T, L read from
//     mrcal's pose derivatives at p = 0 and the unit axes. One Cholesky solve with
//     Nintrinsics + 6 right-hand sides per candidate, then (Nintrinsics + 6)^2 per point.
//
// Thread-compatible: const methods may run concurrently.
#pragma once

#include <array>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/mrcal_problem.h"
#include "calib/solver.h"

namespace camlab::calib {

// A board view to add: its pose and its corners' pixels (x, y per corner, row-major),
// `visible` per corner (the others are missing).
struct AddedView {
  std::array<double, 6> rt_cam_board{};
  std::vector<double> corners_px;
  std::vector<char> visible;
};

// The problem `solution` solved, rebuilt from it (views, weights, poses, warp, stage
// selections in *sel), with `extra` appended as one more frame observed at weight 1 (a
// full-resolution detection) when given. Error "invalid_argument" when the solution is
// not of `data`, "no_covariance" when it kept none.
Result<MrcalProblem> solved_problem(const CalibrationData& data, const Solution& solution,
                                    const AddedView* extra, mrcal_problem_selections_t* sel);

class UncertaintyPredictor {
 public:
  static Result<UncertaintyPredictor> make(const CalibrationData& data, const Solution& solution);

  // Worst-direction stdev (px) at each camera-frame point (m; NaN entries give NaN) with
  // `view` added, at the solution's detection noise. Error "singular".
  Result<std::vector<double>> worst_px_with(const AddedView& view,
                                            const std::vector<std::array<double, 3>>& points) const;

 private:
  const CalibrationData* data_ = nullptr;
  const Solution* solution_ = nullptr;
  MrcalProblem problem_;
  mrcal_problem_selections_t sel_{};
  PackedInformation info_;
};

}  // namespace camlab::calib
