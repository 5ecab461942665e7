// The settings a frame was taken with, as a sidecar's "settings" object
// (docs/capture-folder.md): raw control values with their physical meaning where the
// camera's traits give it, units in the keys.
//
// Reentrant: pure functions.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "capture/capture_plan.h"

namespace camlab::capture {

// From control values by V4L2 name (exposure_time_absolute, auto_exposure, gain,
// focus_absolute, focus_automatic_continuous, iris_absolute): exposure_time_absolute and
// exposure_us (only while exposure is manual; otherwise auto_exposure), gain_control and
// gain (linear, when the unity value is known), focus_position (only with autofocus off)
// with focus_distance_m and lens_to_sensor_mm when known, iris_position and f_number.
nlohmann::json settings_json(const std::map<std::string, int64_t>& controls,
                             const CameraTraits& traits);

// Adds lens_to_sensor_mm and focus_distance_m (null = infinity) for a focus_absolute
// position when the traits know the lens; nothing otherwise.
void add_physical_focus(const CameraTraits& traits, int64_t position, nlohmann::json* settings);

}  // namespace camlab::capture
