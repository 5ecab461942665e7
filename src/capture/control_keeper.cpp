#include "capture/control_keeper.h"

#include <vector>

namespace camlab::capture {

namespace {

// The auto mode each manual control depends on (V4l2Camera switches it off when the
// manual value is written).
const std::map<std::string, std::string>& auto_modes() {
  static const std::map<std::string, std::string> modes = {
      {"exposure_time_absolute", "auto_exposure"},
      {"focus_absolute", "focus_automatic_continuous"},
  };
  return modes;
}

bool is_auto_mode(const std::string& name) {
  for (const auto& [manual, mode] : auto_modes())
    if (mode == name) return true;
  return false;
}

}  // namespace

Result<ControlKeeper> ControlKeeper::snapshot(device::Camera& camera,
                                              const std::set<std::string>& to_write) {
  auto controls = camera.controls();
  if (!controls) return controls.error();
  std::set<std::string> wanted = to_write;
  for (const char* name : {"exposure_time_absolute", "auto_exposure", "gain", "focus_absolute",
                           "focus_automatic_continuous", "iris_absolute"})
    wanted.insert(name);
  for (const auto& name : to_write) {
    auto mode = auto_modes().find(name);
    if (mode != auto_modes().end()) wanted.insert(mode->second);
  }
  ControlKeeper keeper;
  for (const auto& c : *controls)
    if (wanted.count(c.name) && c.type != device::ControlType::kButton)
      keeper.values_[c.name] = c.current;
  for (const auto& name : to_write) {
    auto it = keeper.values_.find(name);
    if (it == keeper.values_.end())
      return make_error("unsupported", "the camera has no readable control '" + name + "' to set");
    keeper.originals_[name] = it->second;
    auto mode = auto_modes().find(name);
    if (mode != auto_modes().end() && keeper.values_.count(mode->second))
      keeper.originals_[mode->second] = keeper.values_[mode->second];
  }
  return keeper;
}

Result<int64_t> ControlKeeper::write(device::Camera& camera, const std::string& name,
                                     int64_t value) {
  auto applied = camera.set_control(name, value);
  if (!applied) return applied.error();
  written_.insert(name);
  values_[name] = *applied;
  auto mode = auto_modes().find(name);
  if (mode != auto_modes().end() && values_.count(mode->second)) {
    auto current = camera.get_control(mode->second);
    if (!current) return current.error();
    if (*current != values_[mode->second])
      written_.insert(mode->second);  // switched by the backend
    values_[mode->second] = *current;
  }
  return *applied;
}

Status ControlKeeper::restore(device::Camera& camera) {
  Status first;
  std::vector<std::string> order;
  for (const auto& name : written_)
    if (!is_auto_mode(name)) order.push_back(name);
  for (const auto& name : written_)
    if (is_auto_mode(name)) order.push_back(name);
  for (const auto& name : order) {
    auto original = originals_.find(name);
    if (original == originals_.end()) continue;
    auto applied = camera.set_control(name, original->second);
    if (applied) {
      values_[name] = *applied;
    } else if (first.ok()) {
      first = make_error(applied.error().code, "restoring " + name + " = " +
                                                   std::to_string(original->second) + ": " +
                                                   applied.error().message);
    }
  }
  written_.clear();
  return first;
}

}  // namespace camlab::capture
