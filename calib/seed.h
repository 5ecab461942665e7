// Seeding of the calibration solve (internal to calib/): focal length without a user
// guess, and per-view board poses by planar PnP on present corners only.
//
// Reentrant.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "calib/calibration_data.h"
#include "calib/lens_model.h"

namespace camlab::calib {

enum class SeedProjection { kPinhole, kStereographic };

struct FocalSeed {
  double focal_px = 0;
  SeedProjection projection = SeedProjection::kPinhole;
  double cost = 0;  // robust reprojection cost of the best candidate
};

// Sweeps focal lengths (imager diagonal / 8 .. x 16, and around `focal_guess_px` when
// > 0) for both projections, principal point at the imager centre. Empty when no view
// gives a pose.
std::optional<FocalSeed> seed_focal(const CalibrationData& data, double focal_guess_px);

// Pose of one view under `model`: corners unprojected through the model to pinhole
// coordinates, then OpenCV's planar PnP (IPPE). Corners beyond 80 deg off-axis, and
// missing ones, are left out. Empty when fewer than 6 corners remain or PnP fails.
std::optional<std::array<double, 6>> pose_from_corners(const CalibrationData& data, int view,
                                                       const LensModel& model);

}  // namespace camlab::calib
