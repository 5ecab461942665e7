#include "service/fleet/fleet_member.h"

#include <vector>

#include "base/log.h"
#include "service/fleet/camera_description.h"
#include "service/jobs/camera_set.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

int64_t ms_since(Clock::time_point then) {
  return std::chrono::duration_cast<milliseconds>(Clock::now() - then).count();
}

}  // namespace

FleetMember::FleetMember(FleetStore& fleet, JobStore& store, CameraSet& cameras,
                         FleetRegistry& registry, FleetOptions options)
    : fleet_(fleet),
      store_(store),
      cameras_(cameras),
      registry_(registry),
      options_(std::move(options)) {}

FleetMember::~FleetMember() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (renewer_.joinable()) renewer_.join();
  if (fencer_.joinable()) fencer_.join();
}

Status FleetMember::start(const std::string& url) {
  options_.url = url;
  // The database was reachable a moment ago (the store opened); a restart of it between
  // then and now is waited out, within bounds.
  Status joined;
  for (int attempt = 0; attempt < 60; ++attempt) {
    joined = fleet_.join(options_.url, options_.lease);
    if (joined || joined.error().code != ErrorCode::kDatabaseUnavailable) break;
    std::this_thread::sleep_for(milliseconds(500));
  }
  if (!joined) return joined.error();
  {
    std::lock_guard lock(mutex_);
    last_renewed_ = Clock::now();
  }
  log_info(log::Category::kDaemon, "joined the fleet as host %s (%s), lease %lld ms",
           options_.host.c_str(), options_.url.c_str(),
           static_cast<long long>(options_.lease.count()));
  publish_cameras();
  if (Status read = registry_.refresh(); !read)
    log_warning(log::Category::kDaemon, "fleet: %s", read.error().message.c_str());
  renewer_ = std::thread([this] { renew_loop(); });
  fencer_ = std::thread([this] { fence_loop(); });
  return {};
}

void FleetMember::stop(const std::string& message) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
  }
  wake_.notify_all();
  if (renewer_.joinable()) renewer_.join();
  if (fencer_.joinable()) fencer_.join();
  if (Status left = fleet_.leave(message); !left)
    log_warning(log::Category::kDaemon,
                "fleet: could not leave cleanly (%s); the other hosts interrupt this host's "
                "jobs when its lease passes",
                left.error().message.c_str());
  else
    log_info(log::Category::kDaemon, "left the fleet");
}

void FleetMember::renew_loop() {
  const milliseconds period = options_.lease / 3;
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    lock.unlock();
    renew_once();
    lock.lock();
    wake_.wait_for(lock, period, [this] { return stopping_; });
  }
}

void FleetMember::renew_once() {
  const Clock::time_point began = Clock::now();
  Result<LeaseRenewal> renewal = fleet_.renew();
  bool fenced;
  {
    std::lock_guard lock(mutex_);
    fenced = fenced_;
    if (renewal && renewal->renewed) {
      last_renewed_ = began;
      wake_.notify_all();  // the fence timer starts over
    }
  }
  if (!renewal) {
    log_warning(log::Category::kDaemon, "fleet: lease not renewed: %s",
                renewal.error().message.c_str());
    return;
  }
  if (!renewal->renewed) {
    // The lease passed (the database was out of reach for longer than it): the fleet may
    // have interrupted this host's jobs already.
    fence("its lease passed before it could be renewed");
    rejoin();
  } else if (fenced) {
    rejoin();
  }
  sweep();
  publish_cameras();
  if (Status read = registry_.refresh(); !read)
    log_warning(log::Category::kDaemon, "fleet: %s", read.error().message.c_str());
}

void FleetMember::fence_loop() {
  const milliseconds fence_after = options_.lease * 4 / 5;
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    const Clock::time_point deadline = last_renewed_ + fence_after;
    if (fenced_ || Clock::now() < deadline) {
      wake_.wait_until(lock, fenced_ ? Clock::now() + options_.lease : deadline);
      continue;
    }
    lock.unlock();
    fence("no lease renewal for " + std::to_string(ms_since(last_renewed_)) + " ms (80% of the " +
          std::to_string(options_.lease.count()) + " ms lease)");
    lock.lock();
  }
}

void FleetMember::fence(const std::string& why) {
  {
    std::lock_guard lock(mutex_);
    if (fenced_) return;
    fenced_ = true;
    fenced_since_ = Clock::now();
  }
  fleet_.set_fenced(true);
  int cancelled = 0;
  for (const auto& worker : cameras_.workers())
    if (const int64_t running = worker->snapshot().running_job; running != 0)
      cancelled += worker->cancel_running(running) ? 1 : 0;
  log_warning(log::Category::kDaemon,
              "fleet: host %s fenced itself: %s; %d running capture(s) stopped (frames kept), "
              "no job is taken until the lease is renewed",
              options_.host.c_str(), why.c_str(), cancelled);
}

void FleetMember::rejoin() {
  Clock::time_point since;
  {
    std::lock_guard lock(mutex_);
    since = fenced_since_;
  }
  // While still fenced: a worker's pending finish (refused while fenced) must not land
  // first and store "cancelled" for a job this host gave up.
  const std::string message =
      "host " + options_.host + " lost its lease (cut off from the database for " +
      std::to_string(ms_since(since)) + " ms or more); the frames written are kept on it";
  // The name first: if another live camlabd took it meanwhile, its jobs are not this
  // host's to interrupt, and this host stays fenced (it takes no work) until the name is
  // free again.
  if (Status held = fleet_.hold_name(options_.lease); !held) {
    log_error(log::Category::kDaemon, "fleet: rejoin: %s", held.error().message.c_str());
    return;
  }
  auto interrupted = store_.interrupt_unfinished(message);
  if (!interrupted) {
    log_warning(log::Category::kDaemon, "fleet: rejoin: %s", interrupted.error().message.c_str());
    return;
  }
  if (Status joined = fleet_.join(options_.url, options_.lease); !joined) {
    log_warning(log::Category::kDaemon, "fleet: rejoin: %s", joined.error().message.c_str());
    return;
  }
  {
    std::lock_guard lock(mutex_);
    fenced_ = false;
    last_renewed_ = Clock::now();
  }
  fleet_.set_fenced(false);
  wake_.notify_all();
  log_warning(log::Category::kDaemon,
              "fleet: host %s joined the fleet again; %d job(s) it had taken ended interrupted",
              options_.host.c_str(), *interrupted);
}

void FleetMember::sweep() {
  auto expired = fleet_.expire_hosts();
  if (!expired) {
    log_warning(log::Category::kDaemon, "fleet: lease sweep: %s", expired.error().message.c_str());
    return;
  }
  for (const ExpiredHost& host : *expired)
    log_warning(log::Category::kDaemon,
                "fleet: host %s is not serving (lease passed or left): %zu of its job(s) "
                "interrupted",
                host.name.c_str(), host.jobs_interrupted.size());
}

void FleetMember::publish_cameras() {
  std::vector<FleetCamera> cameras;
  nlohmann::json fingerprint = nlohmann::json::array();
  for (const auto& worker : cameras_.workers()) {
    const CameraSnapshot s = worker->snapshot();
    FleetCamera camera{options_.host,          s.identity.id, describe_for_fleet(s),
                       s.available && !s.gone, s.running_job, s.queued_jobs};
    fingerprint.push_back({camera.camera_id, camera.available, camera.running_job,
                           camera.queued_jobs, camera.description});
    cameras.push_back(std::move(camera));
  }
  const std::string text = fingerprint.dump();
  if (text == published_) return;
  if (Status published = fleet_.publish_cameras(cameras); !published) {
    log_warning(log::Category::kDaemon, "fleet: publishing the cameras: %s",
                published.error().message.c_str());
    return;
  }
  published_ = text;
}

}  // namespace camlab::service
