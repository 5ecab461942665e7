// The ground truth a virtual frame carries (docs/virtual-camera.md): the camera model as
// mrcal .cameramodel text, each target's pose and distance, projected chessboard corners,
// slanted-edge lines, and the predicted CoC per target.
//
// Reentrant.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "mock_device/render/target_surface.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::mock {

struct CocRange {
  double min_px = 0;
  double max_px = 0;
  double at_origin_px = 0;
};

// Predicted CoC diameter (px) over a target's extent (its corners and its origin), for
// the lens at f_number focused at focus_distance_mm (may be infinite).
CocRange predicted_coc(const CameraSpec& camera, const TargetSurface& surface, double f_number,
                       double focus_distance_mm);

struct TruthInputs {
  const CameraSpec* camera = nullptr;
  const SceneSpec* scene = nullptr;
  const std::vector<TargetSurface>* surfaces = nullptr;
  int view = 0;
  std::vector<double> intrinsics;  // fx fy cx cy distortion..., at this frame's focus
  double f_number = 0;
  double focus_distance_mm = 0;
  double lens_to_sensor_mm = 0;
  double electrons_per_unit_reflectance = 0;
};

nlohmann::json make_frame_truth(const TruthInputs& in);

// The .cameramodel text of the lens at the given intrinsics (full precision).
std::string truth_cameramodel_text(const CameraSpec& camera, const std::vector<double>& intrinsics);

}  // namespace camlab::mock
