// Small camera and scene specs for tests, built in code so each test states the physics
// it depends on.
#pragma once

#include <array>

#include <nlohmann/json.hpp>

#include "mock_device/render/renderer.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::mock::testing {

// A distortion-free camera: f = 8 mm, 4 um pixels, 12 bits, focus motor 1 um per step.
inline nlohmann::json pinhole_camera_json(int width_px = 256, int height_px = 256) {
  return {
      {"name", "test pinhole"},
      {"sensor",
       {{"width_px", width_px},
        {"height_px", height_px},
        {"pixel_pitch_um", 4.0},
        {"bit_depth", 12},
        {"black_level_dn", 64},
        {"full_well_e", 20000},
        {"read_noise_e", 2.0},
        {"quantum_efficiency", 0.6}}},
      {"lens",
       {{"focal_mm", 8.0},
        {"model", "LENSMODEL_PINHOLE"},
        {"f_number_min", 1.4},
        {"f_number_max", 22.0},
        {"focus",
         {{"position_min", 0}, {"position_max", 2000}, {"extension_mm_per_step", 0.001}}}}},
      {"timing", {{"frame_interval_us", 100000}}},
      {"controls", {{"exposure_time_absolute", {{"min", 1}, {"max", 1000}, {"default", 100}}}}},
  };
}

// The same camera with a Bayer sensor: CFA order `cfa`, QE per channel, and longitudinal
// chromatic aberration (focus shift of R, G, B for an object at infinity, mm).
inline nlohmann::json colour_camera_json(int width_px = 256, int height_px = 256,
                                         const char* cfa = "RGGB",
                                         std::array<double, 3> qe = {0.45, 0.6, 0.4},
                                         std::array<double, 3> shift_mm = {0.02, 0.0, -0.015}) {
  nlohmann::json camera = pinhole_camera_json(width_px, height_px);
  camera["name"] = "test colour";
  camera["sensor"]["cfa"] = cfa;
  camera["sensor"]["quantum_efficiency_rgb"] = qe;
  camera["lens"]["chromatic_focus_shift_mm"] = shift_mm;
  return camera;
}

inline nlohmann::json uniform_scene_json(double distance_m = 1.0, double reflectance = 0.5) {
  return {{"illuminance_lux", 1000},
          {"background_reflectance", reflectance},
          {"targets",
           {{{"type", "uniform"},
             {"size_m", {10.0, 10.0}},
             {"light_reflectance", reflectance},
             {"pose", {{"position_m", {0.0, 0.0, distance_m}}}}}}}};
}

inline Renderer make_renderer(const nlohmann::json& camera, const nlohmann::json& scene) {
  auto c = parse_camera_spec(camera);
  auto s = parse_scene_spec(scene);
  if (!c || !s) throw std::runtime_error(!c ? c.error().message : s.error().message);
  auto r = Renderer::create(std::move(*c), std::move(*s));
  if (!r) throw std::runtime_error(r.error().message);
  return std::move(*r);
}

}  // namespace camlab::mock::testing
