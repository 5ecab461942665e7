// Camera rigs: 2 to 8 cameras calibrated jointly on mrcal's C API, intrinsics and
// extrinsics in one solve, with the extrinsics' uncertainty.
//
// The data are one CalibrationData per camera, their views aligned: view v of every camera
// is rig view v, one pose of one board, seen by any subset of the cameras (a camera that
// does not see it has no present corner there). Camera 0 is the reference frame, as in
// mrcal's .cameramodel files (extrinsics = rt_cam_ref, points from camera 0's frame into
// camera i's).
//
// The solve: each camera alone first (solver.h: seed, staged solve, outlier rejection),
// which gives its lens and its board poses; one labelling of each view's corners in every
// camera (board_labels.h: detectors name a plain board's corners from where they start);
// the relative pose of two cameras from every
// view both see (the chordal mean of rt_i_board o rt_j_board^-1); camera i's extrinsics
// along the shortest chain of shared views from camera 0 (cameras connected transitively,
// not all to camera 0); each rig view's board pose from the cameras that see it; then one
// mrcal_optimize over every camera's intrinsics, the extrinsics, the board poses and the
// board's warp, the single solves' outliers staying out and new ones rejected.
//
// The uncertainty: the state's covariance linearised at the optimum, sigma^2 (J^T J)^-1
// J_obs^T J_obs (J^T J)^-1 (the same propagation as the intrinsics', uncertainty.h), with
// sigma the corner noise the residuals show (their RMS per coordinate, corrected for the
// states fitted). Its extrinsics block is each camera's pose relative to camera 0: the
// frames and intrinsics it trades with are marginalised, so the sigma is what the corner
// noise leaves undetermined, not the spread of a fixed-intrinsics fit.
//
// Lens models: one for all (mrcal_optimize solves the rig as one problem), or one a camera
// (mrcal 2.2 solves one model per problem, so the rig is then one mrcal problem a camera,
// stacked and solved together: rig_joint_solve.h). A splined model's frame is not its
// lens's axis and its regularisation biases baselines: the warning "splined_model" says so.
//
// Reentrant: no state between calls.
#pragma once

#include <array>
#include <atomic>
#include <map>
#include <string>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/lens_model.h"
#include "calib/rig/rig_pose.h"

namespace camlab::calib {

inline constexpr int kRigCamerasMin = 2, kRigCamerasMax = 8;

struct RigData {
  std::vector<CalibrationData> cameras;  // one a camera, equal view counts, one board
};

struct RigSolveOptions {
  std::string lensmodel = "LENSMODEL_OPENCV8";  // every camera's model (configured name)
  // Or one a camera (configured names): each camera keeps the model its own data chose,
  // and cameras of different models are solved as stacked per-camera problems
  // (rig_joint_solve.h).
  std::vector<std::string> lensmodels;
  // Solve stacked per-camera problems even when every camera has one model (tests compare
  // the stacked solve with mrcal_optimize's).
  bool stacked_solve = false;
  bool reject_outliers = true;
  bool board_warp = true;
  const std::atomic<bool>* cancel = nullptr;  // set: stop at the next solve ("cancelled")
};

struct RigCamera {
  LensModel model;
  Rt rt_cam_ref{};  // camera 0 -> this camera (identity for camera 0)
  // 1-sigma of rt_cam_ref's rotation vector (deg, per component) and translation (mm),
  // and its full 6 x 6 covariance (rad, m; row-major). Zero for camera 0.
  std::array<double, 3> rotation_sigma_deg{};
  std::array<double, 3> translation_sigma_mm{};
  std::array<double, 36> rt_covariance{};
  double baseline_m = 0;          // distance from camera 0's centre
  double baseline_sigma_mm = 0;   // 1-sigma of that distance
  double rms_px = 0;              // over its inlier corners in the joint solve
  int views = 0;                  // rig views this camera sees (>= 8 corners)
  int inliers = 0, outliers = 0;  // corners
  double single_rms_px = 0;       // its own solve's RMS, before the joint one
};

struct RigSolution {
  std::vector<RigCamera> cameras;
  std::vector<int> views_used;   // rig views in the solve (seen by at least one camera)
  std::vector<Rt> rt_ref_board;  // per used view: the board in camera 0's frame
  std::array<double, 2> calobject_warp{};
  BoardSpec board;
  double rms_px = 0;           // over every camera's inliers
  double corner_sigma_px = 0;  // noise per coordinate the residuals show
  // The covariance (full units) of the calibration's parameters: camera 0's intrinsics,
  // camera 1's, ..., then rt_cam_ref of cameras 1..N-1; parameter_count rows, row-major.
  // Zero rows for a parameter the solve held (PINHOLE's absent distortions).
  int parameter_count = 0;
  std::vector<double> parameter_covariance;
  // Per camera: view -> quarter turns its corner labels took to agree with the other
  // cameras' (board_labels.h); turned_rig_data() applies them.
  std::vector<std::map<int, int>> label_turns;
  std::vector<std::string> warnings;  // degenerate parts of the data, in words
  double solve_s = 0;
};

// Errors: "invalid_argument" (fewer than 2 or more than 8 cameras, views not aligned,
// boards that differ), "bad_lensmodel", "too_few_views" (a camera in fewer than 3 views,
// or a camera that shares no view with the others, directly or through others),
// "solve_failed", "singular" (J^T J not invertible: no uncertainty), "cancelled".
Result<RigSolution> solve_rig(const RigData& data, const RigSolveOptions& options);

// `data` with each camera's views re-labelled as the solve re-labelled them: the corners
// the solution's poses and residuals refer to.
RigData turned_rig_data(const RigData& data, const RigSolution& solution);

}  // namespace camlab::calib
