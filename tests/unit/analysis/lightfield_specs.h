// Specs of small light-field cameras and scenes for the tests, built in code so each test
// states the optics it depends on: the example light-field camera's
// (mock_device/examples/camera_lightfield_9x9.json: 8 mm f/2, 4 um pixels, 12 bits, a focus
// motor of 1 um per step, focused at 0.99 m by default) at a test's size.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace camlab::analysis::testing {

inline nlohmann::json lightfield_camera_json(int width, int height, int views,
                                             const char* grid = "none", double sigma_px = 0.8) {
  return {{"name", "light-field test"},
          {"sensor",
           {{"width_px", width},
            {"height_px", height},
            {"pixel_pitch_um", 4.0},
            {"bit_depth", 12},
            {"black_level_dn", 64},
            {"full_well_e", 20000},
            {"read_noise_e", 2.0},
            {"quantum_efficiency", 0.6}}},
          {"lens",
           {{"focal_mm", 8.0},
            {"baseline_blur_sigma_px", sigma_px},
            {"f_number_min", 2.0},
            {"f_number_max", 16.0},
            {"focus",
             {{"position_min", 0}, {"position_max", 1000}, {"extension_mm_per_step", 0.001}}}}},
          {"controls",
           {{"exposure_time_absolute", {{"min", 1}, {"max", 333}, {"default", 80}}},
            {"focus_absolute", {{"default", 65}}}}},
          {"lightfield", {{"views", {views, views}}, {"microlens_grid", grid}}}};
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
