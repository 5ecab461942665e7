// The calibration solve: a safe seed without a user guess, then a staged mrcal_optimize.
//
//   seed       focal length from a sweep over focal lengths and two projections (pinhole,
//              stereographic): for each candidate, every sampled view's pose by planar PnP
//              (IPPE) on its present corners only, scored by a robust reprojection cost.
//              No homography-only formula: those fail silently on fronto-parallel boards.
//   stage 1    the seed projection's core (fx, fy, cx, cy) and the board poses
//   stage 2    the requested model: core + distortions + poses, with mrcal's regularization
//   stage 3    the same with mrcal's outlier rejection (only now: with a model that cannot
//              yet describe the lens, rejection would throw away good edge corners)
//   stage 4    the board's warp (a paraboloid of two coefficients) joins the solve
//
// The camera sits at the reference frame; board poses are rt_cam_board (rotation vector,
// translation in m), mapping board points into the camera frame.
//
// Reentrant: every call owns its buffers.
#pragma once

#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/lens_model.h"
#include "calib/seed.h"

namespace camlab::calib {

// A solution to start from instead of seeding and staging: cross-validation folds start
// from the full data's solution, whose optimum is near theirs, and reach it in one stage
// instead of five. Not a prior: the fold's own data decide where the solve ends.
struct WarmStart {
  LensModel model;
  std::array<double, 2> calobject_warp{};
  // Per view of the data being solved (same indexing as its views): rt_cam_board, or
  // nullopt for a view to pose by PnP through `model`.
  std::vector<std::optional<std::array<double, 6>>> rt_cam_board;
  // Per view (same indexing): corners the warm solution rejected as outliers. They start
  // out rejected (mrcal never re-admits a corner, so its rejection rounds would otherwise
  // repeat the warm solve's, each a full re-solve).
  std::vector<std::vector<int>> outlier_corners;
};

struct SolveOptions {
  std::string lensmodel = "LENSMODEL_OPENCV8";  // configured mrcal name (see configured_lensmodel)
  double focal_guess_px = 0;  // > 0: searched around as well; never trusted blindly
  bool reject_outliers = true;
  bool board_warp = true;
  // Keep the state covariance for the projection uncertainty (uncertainty.h). Costs a
  // dense inverse of J^T J (n = parameters + 6 per view; ~10-50 ms for 40 views);
  // cross-validation folds turn it off.
  bool compute_covariance = true;
  // Used when warm_start->model.lensmodel == lensmodel; null: seed and stage as above.
  std::shared_ptr<const WarmStart> warm_start;
  // The seed of these data (seed_focal(data, focal_guess_px), seed.h) when the caller
  // already has it: model selection seeds once for all its candidates. Null: computed.
  std::shared_ptr<const FocalSeed> seed;
  // Set (by another thread) to stop: no further mrcal_optimize call starts, and the solve
  // returns "cancelled" once the one running returns. Null: not cancellable.
  const std::atomic<bool>* cancel = nullptr;
};

struct StateCovariance;  // uncertainty.h

struct CornerResidual {
  int view = 0;                 // index into CalibrationData::views
  int corner = 0;               // row-major corner index
  double dx_px = 0, dy_px = 0;  // predicted - observed
  bool outlier = false;         // rejected by the solve
};

struct Solution {
  LensModel model;
  std::vector<int> views_used;                      // indices into CalibrationData::views
  std::vector<std::array<double, 6>> rt_cam_board;  // per used view
  std::array<double, 2> calobject_warp{};           // mrcal's x2, y2 (m)
  std::vector<CornerResidual> residuals;            // every present corner of the used views
  double rms_px = 0;                                // over inliers, sqrt(mean(dx^2 + dy^2))
  double worst_px = 0;                              // largest inlier residual
  int inliers = 0;
  int outliers = 0;
  double seed_focal_px = 0;
  std::string seed_projection;  // "pinhole" or "stereographic"
  double solve_s = 0;           // wall time of the whole solve, seeding included
  BoardSpec board;
  std::vector<char> view_downweighted;  // per used view: kept at weight 1e-3 (mis-observed)
  // Var(state) / sigma^2 of the final solve (uncertainty.h); shared and immutable, so
  // copies of a Solution stay cheap. Null when not computed; covariance_error says why.
  std::shared_ptr<const StateCovariance> covariance;
  std::string covariance_error;
};

// Calibrates one camera. Errors: "too_few_views" (fewer than 2 views with 8+ corners),
// "seed_failed", "solve_failed" (mrcal did not converge to finite values), "cancelled"
// (options.cancel was set).
Result<Solution> solve(const CalibrationData& data, const SolveOptions& options);

// The full data's solution `full` as a warm start for a solve of the views
// data.views[fold_views[k]] (a cross-validation fold, a subset): its model and warp, the
// poses of the views it used (others posed by PnP), and the corners it rejected, except
// in views it down-weighted, which the subset judges afresh.
std::shared_ptr<const WarmStart> warm_start_from(const Solution& full,
                                                 const std::vector<int>& fold_views);

// With `model` fixed, fits the poses of `views` (indices into data.views) and returns
// their residuals (outlier rejection off). Used to score a model on held-out views.
Result<Solution> fit_poses(const CalibrationData& data, const LensModel& model,
                           const std::array<double, 2>& calobject_warp,
                           const std::vector<int>& views);

// The pixel of board corner `corner` (row-major index) for a board at rt_cam_board with
// mrcal's warp, through `model`. Errors from the projection are passed on.
Result<std::array<double, 2>> project_board_corner(const LensModel& model, const BoardSpec& board,
                                                   const std::array<double, 6>& rt_cam_board,
                                                   const std::array<double, 2>& calobject_warp,
                                                   int corner);

// Root mean square of the smallest `keep` share of the residual lengths (keep = 0.98
// ignores up to 2% gross outliers when comparing models on held-out views).
double trimmed_rms_px(const std::vector<CornerResidual>& residuals, double keep);

}  // namespace camlab::calib
