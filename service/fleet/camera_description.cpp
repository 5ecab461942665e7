#include "service/fleet/camera_description.h"

#include <string>

#include "device/camera_json.h"

namespace camlab::service {

namespace {

nlohmann::json traits_json(const capture::CameraTraits& traits) {
  return {{"sensor_bit_depth", traits.sensor_bit_depth},
          {"black_level_dn", traits.black_level_dn},
          {"isp_subtracts_black", traits.isp_subtracts_black},
          {"gain_unity", traits.gain_unity},
          {"f_number_by_iris_position", traits.f_number_by_iris_position},
          {"focal_mm", traits.focal_mm},
          {"focus_extension_mm_per_step", traits.focus_extension_mm_per_step}};
}

// The inverse of device/camera_json.cpp's type names.
device::ControlType control_type(const std::string& name) {
  using device::ControlType;
  if (name == "integer") return ControlType::kInteger;
  if (name == "boolean") return ControlType::kBoolean;
  if (name == "menu") return ControlType::kMenu;
  if (name == "integer_menu") return ControlType::kIntegerMenu;
  if (name == "button") return ControlType::kButton;
  if (name == "integer64") return ControlType::kInteger64;
  return ControlType::kOther;
}

device::ControlInfo control_from(const nlohmann::json& json) {
  device::ControlInfo c;
  c.id = json.value("id", 0u);
  c.name = json.value("name", "");
  c.label = json.value("label", "");
  c.type = control_type(json.value("type", "other"));
  c.minimum = json.value("min", int64_t{0});
  c.maximum = json.value("max", int64_t{0});
  c.step = json.value("step", int64_t{1});
  c.default_value = json.value("default", int64_t{0});
  c.current = json.value("current", int64_t{0});
  c.unit = json.value("unit", "");
  c.read_only = json.value("read_only", false);
  c.inactive = json.value("inactive", false);
  if (json.contains("menu"))
    for (const auto& item : json["menu"])
      c.menu.emplace_back(item.value("value", int64_t{0}), item.value("name", ""));
  return c;
}

device::PixelFormatInfo format_from(const nlohmann::json& json) {
  device::PixelFormatInfo f;
  f.fourcc = json.value("fourcc", "");
  f.description = json.value("description", "");
  for (const auto& size : json.value("sizes", nlohmann::json::array())) {
    device::FrameSizeInfo s;
    s.width = size.value("width_px", 0u);
    s.height = size.value("height_px", 0u);
    for (const auto& interval : size.value("intervals", nlohmann::json::array()))
      s.intervals.push_back({interval.value("numerator", 0u), interval.value("denominator", 0u)});
    f.sizes.push_back(std::move(s));
  }
  return f;
}

}  // namespace

nlohmann::json describe_for_fleet(const CameraSnapshot& snapshot) {
  nlohmann::json json = snapshot.description;
  // The snapshot's lists are what the worker last read; the description may predate them.
  json["controls"] = nlohmann::json::array();
  for (const auto& c : snapshot.controls) json["controls"].push_back(device::to_json(c));
  json["formats"] = nlohmann::json::array();
  for (const auto& f : snapshot.formats) json["formats"].push_back(device::to_json(f));
  json["traits"] = traits_json(snapshot.traits);
  json["transport"] = snapshot.transport;
  return json;
}

Result<PublishedCamera> read_published_camera(const nlohmann::json& description) {
  if (!description.is_object() || !description.contains("controls") ||
      !description.contains("formats") || !description["controls"].is_array() ||
      !description["formats"].is_array())
    return make_error("invalid_argument",
                      "the camera's published description has no controls or formats (its "
                      "host has not opened it yet)");
  PublishedCamera camera;
  try {
    for (const auto& c : description["controls"]) camera.controls.push_back(control_from(c));
    for (const auto& f : description["formats"]) camera.formats.push_back(format_from(f));
    const nlohmann::json traits = description.value("traits", nlohmann::json::object());
    camera.traits.sensor_bit_depth = traits.value("sensor_bit_depth", 0);
    camera.traits.black_level_dn = traits.value("black_level_dn", 0);
    camera.traits.isp_subtracts_black = traits.value("isp_subtracts_black", false);
    camera.traits.gain_unity = traits.value("gain_unity", 0);
    camera.traits.f_number_by_iris_position =
        traits.value("f_number_by_iris_position", std::vector<double>{});
    camera.traits.focal_mm = traits.value("focal_mm", 0.0);
    camera.traits.focus_extension_mm_per_step = traits.value("focus_extension_mm_per_step", 0.0);
  } catch (const nlohmann::json::exception& e) {
    return make_error("invalid_argument",
                      std::string("the camera's published description does not read: ") + e.what());
  }
  return camera;
}

}  // namespace camlab::service
