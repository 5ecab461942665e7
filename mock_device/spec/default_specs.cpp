#include "mock_device/spec/default_specs.h"

#include <cstdlib>

namespace camlab::mock {

namespace {

const char* const kCameraSpec = R"json({
  "name": "camlab virtual 640x480 (OPENCV4, 8 mm)",
  "sensor": {"width_px": 640, "height_px": 480, "pixel_pitch_um": 4.0, "bit_depth": 10, "black_level_dn": 32,
             "full_well_e": 12000, "read_noise_e": 3.0, "shot_noise": true, "quantum_efficiency": 0.65},
  "lens": {"focal_mm": 8.0, "model": "LENSMODEL_OPENCV4", "distortion": [-0.05, 0.01, 0.0, 0.0],
           "f_number_min": 1.4, "f_number_max": 16.0, "iris": {"f_numbers": [16, 11, 8, 5.6, 4, 2.8, 2, 1.4]},
           "focus": {"position_min": 0, "position_max": 1000, "extension_mm_per_step": 0.001}},
  "timing": {"frame_interval_us": 33333, "control_latency_frames": 3},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 333, "default": 50},
               "gain": {"min": 100, "max": 1600, "default": 100, "unity": 100},
               "focus_absolute": {"default": 65}, "iris_absolute": {"default": 5}}
})json";

// Three of the four edges of mock_device/examples/scene_slanted_edges.json: the 0.4 m one
// is 8.6 px out of focus and costs the renderer 4x the aperture samples, too slow for the
// frame clock on a small machine.
const char* const kSceneSpec = R"json({
  "name": "slanted edges at 0.7, 1 and 2 m (5 degrees), for blur and CoC measurement",
  "illuminance_lux": 1000, "background_reflectance": 0.18,
  "targets": [
    {"type": "slanted_edge", "name": "edge_0.7m", "size_m": [0.07, 0.07], "angle_deg": 5,
     "dark_reflectance": 0.1, "light_reflectance": 0.8, "pose": {"position_m": [0.06, -0.035, 0.7]}},
    {"type": "slanted_edge", "name": "edge_1.0m", "size_m": [0.1, 0.1], "angle_deg": 5,
     "dark_reflectance": 0.1, "light_reflectance": 0.8, "pose": {"position_m": [-0.09, 0.06, 1.0]}},
    {"type": "slanted_edge", "name": "edge_2.0m", "size_m": [0.2, 0.2], "angle_deg": 5,
     "dark_reflectance": 0.1, "light_reflectance": 0.8, "pose": {"position_m": [0.17, 0.11, 2.0]}}]
})json";

template <class Spec>
Spec parsed_or_abort(Result<Spec> spec) {
  // A constant spec that does not parse is a bug of this file, caught by its unit test.
  if (!spec) std::abort();
  return std::move(*spec);
}

}  // namespace

const nlohmann::json& default_camera_spec_json() {
  static const nlohmann::json spec = nlohmann::json::parse(kCameraSpec);
  return spec;
}

const nlohmann::json& default_scene_spec_json() {
  static const nlohmann::json spec = nlohmann::json::parse(kSceneSpec);
  return spec;
}

CameraSpec default_camera_spec() {
  return parsed_or_abort(parse_camera_spec(default_camera_spec_json()));
}

SceneSpec default_scene_spec() {
  return parsed_or_abort(parse_scene_spec(default_scene_spec_json()));
}

}  // namespace camlab::mock
