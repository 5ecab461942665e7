#include "service/fleet/fleet.h"

#include "service/fleet/sync_captures.h"
#include "service/jobs/camera_set.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace {

// Reserved first: GCC 12 warns (-Warray-bounds, a false positive) on substr() + "...".
std::string clipped(const std::string& s) {
  if (s.size() <= 100) return s;
  std::string first_100;
  first_100.reserve(103);
  first_100.append(s, 0, 100).append("...");
  return first_100;
}

// "cam@host-a, cam@host-b" for a not_found message.
std::string camera_list(const std::vector<FleetHost>& hosts) {
  std::string list;
  for (const FleetHost& host : hosts)
    if (host.state == "live")
      for (const FleetCamera& camera : host.cameras)
        list += (list.empty() ? "" : ", ") + fleet_camera_id(camera.camera_id, host.name);
  return list.empty() ? "none" : list;
}

}  // namespace

Fleet::Fleet(FleetStore& fleet, JobStore& store, CameraSet& cameras, ComputeWorker& compute,
             FleetOptions options, int max_queued_jobs)
    : fleet_(fleet),
      store_(store),
      cameras_(cameras),
      options_(std::move(options)),
      max_queued_jobs_(max_queued_jobs),
      registry_(fleet),
      member_(fleet, store, cameras, registry_, options_),
      dispatcher_(fleet, store, cameras, compute, registry_, options_.poll),
      sync_(std::make_unique<SyncCaptures>(*this)) {}

Fleet::~Fleet() = default;

Status Fleet::start(const std::string& url) {
  if (Status joined = member_.start(url); !joined) return joined;
  dispatcher_.start();
  sync_->start();
  return {};
}

void Fleet::stop_taking_jobs() {
  sync_->stop();
  dispatcher_.stop();
}

void Fleet::leave(const std::string& message) {
  stop_taking_jobs();
  member_.stop(message);
}

Result<CameraTarget> Fleet::resolve(const std::string& id) {
  auto [camera_id, host] = split_fleet_camera_id(id);
  CameraTarget target;
  target.camera_id = camera_id;
  target.host = host.empty() ? options_.host : host;
  if (target.host == options_.host) {
    std::shared_ptr<CameraWorker> worker = cameras_.find(camera_id);
    if (!worker)
      return make_error("not_found", "no camera '" + clipped(id) + "' (cameras of the fleet: " +
                                         camera_list(registry_.hosts()) + ")");
    return local_camera_target(std::move(worker), target.host, describe_for_fleet);
  }
  const std::optional<FleetHost> owner = registry_.host(target.host);
  if (!owner)
    return make_error("not_found", "no host '" + clipped(target.host) +
                                       "' in the fleet (cameras of the fleet: " +
                                       camera_list(registry_.hosts()) + ")");
  if (owner->state != "live")
    return make_error("host_unavailable", "host " + owner->name + " is not serving (" +
                                              owner->state + "); its cameras take no jobs");
  const std::optional<FleetCamera> camera = registry_.camera(target.host, camera_id);
  if (!camera)
    return make_error("not_found",
                      "host " + owner->name + " has no camera '" + clipped(camera_id) +
                          "' (cameras of the fleet: " + camera_list(registry_.hosts()) + ")");
  auto published = read_published_camera(camera->description);
  if (!published) return published.error();
  target.camera = std::move(*published);
  target.description = camera->description;
  target.available = camera->available;
  target.unavailable_reason = camera->available ? "" : "its host reports it unavailable";
  return target;
}

Result<JobRecord> Fleet::submit(const CameraTarget& target, const std::string& kind,
                                const nlohmann::json& request, int frames_total) {
  if (!target.available)
    return make_error("no_device", "camera " + target.fleet_id() +
                                       " is not available: " + target.unavailable_reason);
  auto waiting = fleet_.waiting(target.host, target.camera_id);
  if (!waiting) return waiting.error();
  if (*waiting >= max_queued_jobs_)
    return make_error("too_many_jobs", "camera " + target.fleet_id() + " already has " +
                                           std::to_string(*waiting) + " jobs waiting (limit " +
                                           std::to_string(max_queued_jobs_) + "); retry later");
  return fleet_.submit(target.host, kind, target.camera_id, request,
                       kind == "capture" ? "captures/job-" : "", frames_total);
}

void Fleet::cancel_running(int64_t id) { (void)fleet_.request_cancel(id); }

std::map<std::string, HostClock> Fleet::clocks() {
  std::map<std::string, HostClock> out;
  for (const FleetHost& host : registry_.hosts())
    out[host.name] = {host.clock_offset_us, host.clock_uncertainty_us};
  return out;
}

Result<std::string> Fleet::url_of(const std::string& name) {
  const std::optional<FleetHost> host = registry_.host(name);
  if (!host) return make_error("host_unavailable", "no host '" + clipped(name) + "' in the fleet");
  if (host->state != "live")
    return make_error("host_unavailable",
                      "host " + name + " is not serving (" + host->state +
                          "); what it captured stays on its disk until it is back");
  if (host->starting())
    return make_error("host_unavailable",
                      "host " + name + " is starting and does not serve yet; ask again shortly");
  return host->url;
}

}  // namespace camlab::service
