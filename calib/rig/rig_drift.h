// Whether a rig has moved between two calibrations: each camera's pose relative to camera
// 0 in two rig reports (rig.json, rig_calibrate.h) compared against the noise both
// calibrations state. The difference of the two rt_cam_ref, weighed by the sum of their
// covariances, is a chi-square of 6 degrees of freedom when nothing moved; above 22.46
// (0.1% of draws of an unmoved rig) the camera is reported as moved. A drift smaller than
// the two calibrations can see is "unchanged", never "the same".
//
// Reentrant.
#pragma once

#include <nlohmann/json.hpp>

#include "base/result.h"

namespace camlab::calib {

inline constexpr double kRigDriftChiSquare6Dof = 22.46;  // 99.9% of an unmoved rig's draws

// Per camera 1..N-1: rotation_deg and translation_mm between the two poses, the
// chi-square, and "moved" or "unchanged"; the cameras' count must agree. Errors:
// "invalid_argument" (not rig reports, or rigs of different sizes), "singular" (a
// covariance that cannot be inverted).
Result<nlohmann::json> rig_drift(const nlohmann::json& before, const nlohmann::json& after);

}  // namespace camlab::calib
