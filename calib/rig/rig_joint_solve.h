// The joint rig solve when the cameras have different lens models (a fisheye beside
// pinhole lenses). mrcal 2.2 solves one lens model for every camera of a problem, and the
// one model that reaches a fisheye's field for every camera is the splined one, whose
// frame is not a lens's axis (a turn trades with its knots) and whose regularisation biases
// baselines. So each camera keeps the model its own data chose, and the rig is solved as N
// mrcal problems, one a camera (its intrinsics, its extrinsics, every rig view's board pose,
// the board's warp), tied by the board poses and warp they share: mrcal_optimizer_callback
// gives each one's residuals and Jacobian (mrcal's projections, gradients, regularisation
// and variable scaling, unchanged), and a Levenberg-Marquardt loop here solves the stacked
// problem. On one model for all it reaches the state mrcal_optimize reaches
// (rig_solver_test.cpp compares them).
//
// Outliers: the single-camera solves' rejections stand (mrcal's, per camera); the joint
// solve adds a corner whose residual exceeds 5 sigma of the joint fit (a Gaussian residual
// in 2-D goes past that once in about 270000 corners) and solves again, at most 5 times.
//
// Internal to calib/rig/. Reentrant.
#pragma once

#include <atomic>

#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/rig/rig_problem.h"

namespace camlab::calib {

// The information of a solved rig problem at its optimum, in mrcal's packed units: J^T J
// over every row (board and regularisation) and J_obs^T J_obs over the board rows, the
// scale that unpacks each state (full = packed * scale), and where each camera's
// parameters sit.
struct RigInformation {
  cv::Mat jtj, jobs;
  std::vector<double> unpack_scale;
  RigStateLayout layout;
};

// Solves `p` in place (its intrinsics, extrinsics, frames and warp, p->x, and the outliers
// in p->pool) and returns the information at the optimum, from the solve's last
// evaluation. Errors: "solve_failed" (no convergence, a non-finite state), "cancelled".
Result<RigInformation> optimize_rig_per_camera(RigProblem* p, const BoardSpec& board,
                                               const std::atomic<bool>* cancel);

}  // namespace camlab::calib
