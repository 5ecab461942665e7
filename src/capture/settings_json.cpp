#include "capture/settings_json.h"

#include <linux/videodev2.h>

#include <cmath>

#include "optics/optics.h"

namespace camlab::capture {

void add_physical_focus(const CameraTraits& traits, int64_t position, nlohmann::json* settings) {
  if (!(traits.focal_mm > 0) || !(traits.focus_extension_mm_per_step > 0)) return;
  const double lens_to_sensor_mm =
      traits.focal_mm + static_cast<double>(position) * traits.focus_extension_mm_per_step;
  auto focus_mm = optics::focus_distance_mm(traits.focal_mm, lens_to_sensor_mm);
  if (!focus_mm) return;  // behind the focal plane: no real focus distance
  (*settings)["lens_to_sensor_mm"] = lens_to_sensor_mm;
  // An infinite distance is JSON null (docs/capture-folder.md).
  (*settings)["focus_distance_m"] =
      std::isfinite(*focus_mm) ? nlohmann::json(*focus_mm / 1e3) : nlohmann::json();
}

nlohmann::json settings_json(const std::map<std::string, int64_t>& controls,
                             const CameraTraits& traits) {
  nlohmann::json s = nlohmann::json::object();
  auto value = [&](const char* name) -> const int64_t* {
    auto it = controls.find(name);
    return it == controls.end() ? nullptr : &it->second;
  };
  const int64_t* exposure_mode = value("auto_exposure");
  if (exposure_mode && *exposure_mode != V4L2_EXPOSURE_MANUAL) {
    s["auto_exposure"] = *exposure_mode;  // the exposure time in effect is the camera's choice
  } else if (const int64_t* exposure = value("exposure_time_absolute")) {
    s["exposure_time_absolute"] = *exposure;
    s["exposure_us"] = static_cast<double>(*exposure) * 100.0;  // V4L2 unit: 100 us
  }
  if (const int64_t* gain = value("gain")) {
    s["gain_control"] = *gain;
    if (traits.gain_unity > 0) s["gain"] = static_cast<double>(*gain) / traits.gain_unity;
  }
  const int64_t* focus_auto = value("focus_automatic_continuous");
  if (focus_auto && *focus_auto != 0) {
    s["focus_auto"] = true;
  } else if (const int64_t* focus = value("focus_absolute")) {
    s["focus_position"] = *focus;
    add_physical_focus(traits, *focus, &s);
  }
  if (const int64_t* iris = value("iris_absolute")) {
    s["iris_position"] = *iris;
    const auto& table = traits.f_number_by_iris_position;
    if (*iris >= 0 && *iris < static_cast<int64_t>(table.size()))
      s["f_number"] = table[static_cast<size_t>(*iris)];
  }
  return s;
}

}  // namespace camlab::capture
