// A calibrated rig read back from the folder `camlab calibrate --rig --out DIR` writes:
// camera-0.cameramodel, camera-1.cameramodel, ... (mrcal's format, read by mrcal's own
// reader, so models written by mrcal's tools in that naming load too) and, when present,
// rig.json, whose uncertainty the models do not carry: the corner noise, each camera's
// rt_cam_ref covariance and, for rigs of up to kRigCovarianceStoredMax parameters, the whole
// calibration's parameter covariance (what a triangulation's uncertainty needs).
//
// Reentrant.
#pragma once

#include <filesystem>

#include "base/result.h"
#include "calib/rig/rig_solver.h"

namespace camlab::calib {

// rig.json carries the parameter covariance up to this many parameters (a 200 x 200
// matrix is about 1 MB of JSON; 4 OPENCV8 cameras have 66, a splined one alone 324).
inline constexpr int kRigCovarianceStoredMax = 200;

// The rig's cameras (model, rt_cam_ref) and, from rig.json, corner_sigma_px, each camera's
// rt_covariance and sigmas, and parameter_covariance when stored. Errors: "io_error" (no
// camera-0.cameramodel and camera-1.cameramodel, or a file that does not read),
// "invalid_argument" (a rig.json whose cameras disagree with the models). The cameras'
// models may differ (each camera keeps its own, rig_solver.h).
Result<RigSolution> read_rig_folder(const std::filesystem::path& dir);

}  // namespace camlab::calib
