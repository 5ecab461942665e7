// The fleet as this host last read it from the database: every host with its lease and
// cameras. The member refreshes it at every lease renewal (service/fleet/fleet_member.h);
// lookups that find nothing read the database once more, so a host that joined a moment
// ago is found at once.
//
// A camera of the fleet is named `CAMERA@HOST` ("v4l2:platform:camlab-vcam-0@line-3"):
// camera ids are only unique on their host (two hosts' virtual cameras share one).
//
// Thread-safe: one mutex around the copy.
#pragma once

#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "base/result.h"
#include "service/store/fleet_store.h"

namespace camlab::service {

// "CAMERA@HOST" from its parts, and back (split at the last '@'; no '@': this host's).
std::string fleet_camera_id(const std::string& camera_id, const std::string& host);
std::pair<std::string, std::string> split_fleet_camera_id(const std::string& id);

class FleetRegistry {
 public:
  explicit FleetRegistry(FleetStore& fleet) : fleet_(fleet) {}

  // Reads the fleet from the database.
  Status refresh();
  std::vector<FleetHost> hosts() const;
  // The host named `name`, refreshing once unless the copy at hand is live with a URL
  // (a starting host holds its name with none yet; a restarted one was expired).
  std::optional<FleetHost> host(const std::string& name);
  // Camera `camera_id` of `host` (refreshing once if unknown).
  std::optional<FleetCamera> camera(const std::string& host, const std::string& camera_id);

 private:
  std::optional<FleetHost> find_host(const std::string& name) const;

  FleetStore& fleet_;
  mutable std::mutex mutex_;
  std::vector<FleetHost> hosts_;
};

}  // namespace camlab::service
