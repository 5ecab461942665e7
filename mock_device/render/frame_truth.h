// The ground truth a virtual frame carries (docs/virtual-camera.md): the camera model as
// mrcal .cameramodel text, each target's pose and distance, projected chessboard corners,
// slanted-edge lines, and the predicted CoC per target; for a colour sensor also the
// CFA and, per channel, its optics, predicted CoC and expected signal.
//
// Reentrant.
#pragma once

#include <array>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "mock_device/render/channel_optics.h"
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

// The same for one colour channel's own focus (channel_optics.h).
CocRange predicted_coc(const ChannelOptics& optics, double pixel_pitch_um,
                       const TargetSurface& surface);

// What the truth says of one colour channel of a frame.
struct ChannelTruthInputs {
  ChannelOptics optics;
  double quantum_efficiency = 0;
  double electrons_per_unit_reflectance = 0;  // with this channel's QE
  int aperture_samples = 0;                   // lens samples per pixel (0: not sampled)
};

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
  double gain = 1;                             // linear analogue gain
  std::array<ChannelTruthInputs, 3> channels;  // R, G, B: colour sensors only
};

nlohmann::json make_frame_truth(const TruthInputs& in);

// The .cameramodel text of the lens at the given intrinsics (full precision).
std::string truth_cameramodel_text(const CameraSpec& camera, const std::vector<double>& intrinsics);

}  // namespace camlab::mock
