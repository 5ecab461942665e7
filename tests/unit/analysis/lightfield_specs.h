// Specs of small light-field cameras and scenes for the tests, built in code so each test
// states the optics it depends on: the example light-field camera's
// (mock_device/examples/camera_lightfield_9x9.json: 8 mm f/2, 4 um pixels, 12 bits, a focus
// motor of 1 um per step, focused at 0.99 m by default) at a test's size: the mock_device
// tests' pinhole camera with the example's aperture range and defaults.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "test_specs.h"  // tests/unit/mock_device: the pinhole test camera

namespace camlab::analysis::testing {

inline nlohmann::json lightfield_camera_json(int width, int height, int views,
                                             const char* grid = "none", double sigma_px = 0.8) {
  nlohmann::json camera = mock::testing::pinhole_camera_json(width, height);
  camera["name"] = "light-field test";
  camera["lens"]["baseline_blur_sigma_px"] = sigma_px;
  camera["lens"]["f_number_min"] = 2.0;  // the iris's default: its widest, f/2
  camera["lens"]["f_number_max"] = 16.0;
  camera["controls"]["exposure_time_absolute"]["default"] = 80;
  camera["controls"]["focus_absolute"] = {{"default", 65}};
  camera["lightfield"] = {{"views", {views, views}}, {"microlens_grid", grid}};
  return camera;
}

// A square target of `type` (slanted_edge, texture, uniform) of side size_m, facing the
// camera at (x, y, z) m; textures have features of 1.5 mm per metre of distance (about
// 3 px for the camera above).
inline nlohmann::json lightfield_target(const char* type, const char* name, double size_m,
                                        double x_m, double y_m, double z_m) {
  nlohmann::json t = {{"type", type},
                      {"name", name},
                      {"size_m", {size_m, size_m}},
                      {"dark_reflectance", 0.1},
                      {"light_reflectance", 0.8},
                      {"pose", {{"position_m", {x_m, y_m, z_m}}}}};
  if (std::string(type) == "slanted_edge") t["angle_deg"] = 5;
  if (std::string(type) == "texture") t["feature_m"] = 0.0015 * z_m, t["seed"] = 7;
  return t;
}

inline nlohmann::json lightfield_scene(const nlohmann::json& targets) {
  return {{"illuminance_lux", 1000}, {"background_reflectance", 0.18}, {"targets", targets}};
}

}  // namespace camlab::analysis::testing
