#include "device/camera_json.h"

namespace camlab::device {

namespace {

const char* type_name(ControlType type) {
  switch (type) {
    case ControlType::kInteger:
      return "integer";
    case ControlType::kBoolean:
      return "boolean";
    case ControlType::kMenu:
      return "menu";
    case ControlType::kIntegerMenu:
      return "integer_menu";
    case ControlType::kButton:
      return "button";
    case ControlType::kInteger64:
      return "integer64";
    case ControlType::kOther:
      return "other";
  }
  return "other";
}

}  // namespace

nlohmann::json to_json(const CameraIdentity& identity) {
  return {{"id", identity.id},     {"backend", identity.backend}, {"path", identity.path},
          {"name", identity.name}, {"driver", identity.driver},   {"bus_info", identity.bus_info}};
}

nlohmann::json to_json(const PixelFormatInfo& format) {
  nlohmann::json sizes = nlohmann::json::array();
  for (const auto& size : format.sizes) {
    nlohmann::json intervals = nlohmann::json::array();
    for (const auto& interval : size.intervals)
      intervals.push_back(
          {{"numerator", interval.numerator},
           {"denominator", interval.denominator},
           {"frame_interval_s", interval.seconds()},
           {"frames_per_second", interval.numerator ? 1.0 / interval.seconds() : 0.0}});
    sizes.push_back(
        {{"width_px", size.width}, {"height_px", size.height}, {"intervals", intervals}});
  }
  return {{"fourcc", format.fourcc}, {"description", format.description}, {"sizes", sizes}};
}

nlohmann::json to_json(const ControlInfo& control) {
  nlohmann::json json = {{"id", control.id},
                         {"name", control.name},
                         {"label", control.label},
                         {"type", type_name(control.type)},
                         {"min", control.minimum},
                         {"max", control.maximum},
                         {"step", control.step},
                         {"default", control.default_value},
                         {"current", control.current},
                         {"unit", control.unit},
                         {"read_only", control.read_only},
                         {"inactive", control.inactive}};
  if (!control.menu.empty()) {
    nlohmann::json menu = nlohmann::json::array();
    for (const auto& [value, name] : control.menu)
      menu.push_back({{"value", value}, {"name", name}});
    json["menu"] = menu;
  }
  return json;
}

nlohmann::json describe_camera(Camera& camera) {
  nlohmann::json json = to_json(camera.identity());
  nlohmann::json errors = nlohmann::json::array();
  json["formats"] = nlohmann::json::array();
  if (auto formats = camera.formats())
    for (const auto& f : *formats) json["formats"].push_back(to_json(f));
  else
    errors.push_back(formats.error().message);
  json["controls"] = nlohmann::json::array();
  if (auto controls = camera.controls())
    for (const auto& c : *controls) json["controls"].push_back(to_json(c));
  else
    errors.push_back(controls.error().message);
  if (!errors.empty()) json["errors"] = errors;
  return json;
}

}  // namespace camlab::device
