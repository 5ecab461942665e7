#include "service/fleet/fleet_registry.h"

namespace camlab::service {

std::string fleet_camera_id(const std::string& camera_id, const std::string& host) {
  return camera_id + "@" + host;
}

std::pair<std::string, std::string> split_fleet_camera_id(const std::string& id) {
  const size_t at = id.rfind('@');
  if (at == std::string::npos) return {id, ""};
  return {id.substr(0, at), id.substr(at + 1)};
}

Status FleetRegistry::refresh() {
  auto hosts = fleet_.hosts();
  if (!hosts) return hosts.error();
  std::lock_guard lock(mutex_);
  hosts_ = std::move(*hosts);
  return {};
}

std::vector<FleetHost> FleetRegistry::hosts() const {
  std::lock_guard lock(mutex_);
  return hosts_;
}

std::optional<FleetHost> FleetRegistry::find_host(const std::string& name) const {
  std::lock_guard lock(mutex_);
  for (const FleetHost& host : hosts_)
    if (host.name == name) return host;
  return std::nullopt;
}

std::optional<FleetHost> FleetRegistry::host(const std::string& name) {
  std::optional<FleetHost> found = find_host(name);
  if (found && found->serving()) return found;
  if (!refresh()) return found;
  return find_host(name);
}

std::optional<FleetCamera> FleetRegistry::camera(const std::string& host,
                                                 const std::string& camera_id) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (auto found = find_host(host))
      for (const FleetCamera& camera : found->cameras)
        if (camera.camera_id == camera_id) return camera;
    if (attempt == 0 && !refresh()) break;
  }
  return std::nullopt;
}

}  // namespace camlab::service
