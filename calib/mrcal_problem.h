// The mrcal problem of one camera (internal to calib/): the camera at the reference frame
// observing a chessboard in N views, in the arrays mrcal_optimize and
// mrcal_optimizer_callback take. Shared by the solver and the uncertainty propagation,
// which must evaluate the Jacobian of exactly the problem that was solved.
//
// Reentrant: plain values.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/mrcal_api.h"

namespace camlab::calib {

// Owns the observation pool: shape (N, rows, cols), z = weight, z < 0 = outlier/missing.
struct MrcalProblem {
  mrcal_lensmodel_t lensmodel{};
  std::vector<double> intrinsics;
  std::vector<mrcal_pose_t> frames;  // rt_cam_board per view (mrcal's frames_toref)
  std::vector<mrcal_observation_board_t> observations;
  std::vector<mrcal_point3_t> pool;
  std::vector<uint8_t> missing;  // per pool entry: not detected (never an inlier)
  mrcal_calobject_warp_t warp{};
  std::vector<double> x;  // measurements after the last solve
  int imagersize[2] = {0, 0};
  const std::atomic<bool>* cancel = nullptr;  // set: optimize no more (SolveOptions::cancel)
};

// The problem of `views` (indices into data.views), poses zero, pool at the corners'
// own weights.
MrcalProblem make_mrcal_problem(const CalibrationData& data, const std::vector<int>& views);

// The stack a thread needs to run mrcal_optimize or mrcal_optimizer_callback on `p`:
// mrcal keeps arrays of the state's and the measurements' size on the stack, so the
// calls run on a thread of this size (base/stack_thread.h), whatever thread asked.
size_t solver_stack_bytes(const MrcalProblem& p);

// What a stage optimises. The camera never moves (it is the reference frame).
mrcal_problem_selections_t mrcal_selections(bool core, bool distortions, bool warp, bool regularize,
                                            bool outliers);

// The information of the problem `p` at its current state, in mrcal's packed (unitless)
// state b* = D^-1 b: J^T J over every measurement (regularization included) and
// J_obs^T J_obs over the board observations' rows (uncertainty.h), and where each part of
// the state sits in b*. Error "solve_failed" when mrcal's callback fails.
struct PackedInformation {
  int nstate = 0;
  cv::Mat jtj, jobs;                 // nstate x nstate, CV_64F
  std::vector<double> unpack;        // D: full units = D * packed, per state
  std::vector<int> intrinsic_index;  // per intrinsic of the model: its index in b*, or -1
  std::vector<int> frame_index;      // per frame: index of its r (then t) in b*, or -1
  int warp_index = -1;               // index of the board warp's two terms, or -1
  std::vector<double> x;             // the measurements at the state
};
Result<PackedInformation> packed_information(const MrcalProblem& p, const BoardSpec& board,
                                             mrcal_problem_selections_t sel);

struct StateCovariance;
// The state covariance of the solved problem `p` (uncertainty.h), from mrcal's Jacobian
// at its current state with the stage selections `sel`. `downweighted`: per view, kept at
// a weight of 1e-3 (left out of the mean of the boards). Errors: "singular" (J^T J cannot
// be inverted: some state is not determined by the data), "mrcal_failed".
Result<StateCovariance> state_covariance(const MrcalProblem& p, const BoardSpec& board,
                                         mrcal_problem_selections_t sel,
                                         const std::vector<char>& downweighted);

}  // namespace camlab::calib
