// The joint rig problem in mrcal's arrays (internal to calib/rig/): shared by the solve
// through mrcal_optimize (every camera one lens model, rig_solver.cpp) and the solve with a
// lens model per camera (rig_joint_solve.h).
//
// Camera c's intrinsics at intrinsics_at[c] in `intrinsics` (nparams[c] of them), the
// extrinsics of cameras 1..N-1 (camera 0 is the reference), one frame per used rig view,
// one observation per (used view, camera that solved it), ordered by frame as mrcal wants;
// `pool` holds each observation's corners (z: weight, negative for an outlier).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "calib/mrcal_api.h"

namespace camlab::calib {

struct RigProblem {
  std::vector<std::string> lensmodel_names;   // per camera, configured (rig_solver.h)
  std::vector<mrcal_lensmodel_t> lensmodels;  // per camera
  std::vector<int> nparams;                   // per camera
  std::vector<int> intrinsics_at;             // per camera: its first value in `intrinsics`
  int ncameras = 0;
  std::vector<double> intrinsics;
  std::vector<mrcal_pose_t> extrinsics;
  std::vector<mrcal_pose_t> frames;
  std::vector<mrcal_observation_board_t> observations;
  std::vector<mrcal_point3_t> pool;
  std::vector<uint8_t> missing;  // per pool entry: not detected
  std::vector<int> imagersizes;
  mrcal_calobject_warp_t warp{};
  bool board_warp = true;
  bool reject_outliers = true;
  // The board measurements' residuals after the solve: x = weight * (projected - observed),
  // two per pool entry in pool order (0 for outliers and missing corners).
  std::vector<double> x;

  // Whether every solved value is a number (a diverged solve leaves NaN or infinity).
  bool finite_state() const {
    for (double v : intrinsics)
      if (!std::isfinite(v)) return false;
    for (const auto* poses : {&extrinsics, &frames})
      for (const auto& pose : *poses)
        for (int k = 0; k < 3; ++k)
          if (!std::isfinite(pose.r.xyz[k]) || !std::isfinite(pose.t.xyz[k])) return false;
    return std::isfinite(warp.x2) && std::isfinite(warp.y2);
  }

  // The stack mrcal's solver needs for this problem (it keeps per-state arrays on it).
  size_t solver_stack_bytes() const {
    const size_t state = intrinsics.size() + 6 * (extrinsics.size() + frames.size()) + 2;
    return (size_t{16} << 20) + 64 * state + 16 * 2 * pool.size();
  }

  bool one_lensmodel() const {
    for (const auto& name : lensmodel_names)
      if (name != lensmodel_names[0]) return false;
    return true;
  }
};

// mrcal's selections for a rig problem whose cameras have `nparams` intrinsics: the core
// always; distortions, and mrcal's regularisation of them, for models with more than the
// core's 4 (PINHOLE, STEREOGRAPHIC, LONLAT and LATLON have none).
inline mrcal_problem_selections_t rig_selections(int nparams, bool extrinsics, bool board_warp,
                                                 bool outlier_rejection) {
  mrcal_problem_selections_t sel{};
  sel.do_optimize_intrinsics_core = true;
  sel.do_optimize_intrinsics_distortions = nparams > 4;
  sel.do_optimize_extrinsics = extrinsics;
  sel.do_optimize_frames = true;
  sel.do_optimize_calobject_warp = board_warp;
  sel.do_apply_regularization = nparams > 4;
  sel.do_apply_outlier_rejection = outlier_rejection;
  return sel;
}

// Where the covariance of a solve finds each camera's parameters: the state index of
// camera c's first intrinsic (-1 when none is solved), how many of its intrinsics are
// solved (the first ones: PINHOLE-like models hold no distortion), and the index of camera
// c's rt_cam_ref (c >= 1; index 0 unused).
struct RigStateLayout {
  std::vector<int> intrinsics_state_at, intrinsics_solved, extrinsics_state_at;
};

}  // namespace camlab::calib
