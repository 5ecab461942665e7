// This host's membership of a fleet (docs/fleet.md): it joins with a lease, renews it
// every third of the lease, publishes its cameras and reads the fleet's, and expires the
// leases of hosts that stopped renewing theirs (interrupting their jobs, exactly once
// across the fleet: fleet_store.h).
//
// Cut off: when no renewal has succeeded for 80% of the lease (a timer of its own, so a
// renewal stuck on a dead network cannot delay it), the host fences itself before any
// other host can expire it: it cancels its running captures (frames kept) and the store
// refuses its job steps, so nothing is written as running for a job the fleet is about to
// interrupt. Once the database answers again it interrupts what it had taken (exactly
// once with the other hosts' sweeps), joins again with a fresh lease and takes work again.
//
// Thread-safe: start() and stop() from the daemon's thread; two threads of its own.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "base/result.h"
#include "service/fleet/fleet_registry.h"
#include "service/store/fleet_store.h"

namespace camlab::service {

class CameraSet;
class JobStore;

struct FleetOptions {
  std::string host;  // this host's name (--host-name)
  std::string url;   // where clients reach its API (--advertise-url; set by start())
  std::chrono::milliseconds lease{10000};
  // How often the dispatcher looks for work without a notification (notifications sent
  // while its connection was down are lost).
  std::chrono::milliseconds poll{500};
};

class FleetMember {
 public:
  FleetMember(FleetStore& fleet, JobStore& store, CameraSet& cameras, FleetRegistry& registry,
              FleetOptions options);
  ~FleetMember();
  FleetMember(const FleetMember&) = delete;
  FleetMember& operator=(const FleetMember&) = delete;

  // Joins as reachable at `url` (trying again while the database is unavailable, for up
  // to 30 s), publishes the cameras, reads the fleet and starts renewing.
  Status start(const std::string& url);
  // Stops renewing and leaves the fleet: this host's unfinished jobs end interrupted with
  // `message` (call after the workers have stopped).
  void stop(const std::string& message);

  const FleetOptions& options() const { return options_; }

 private:
  void renew_loop();
  void fence_loop();
  void renew_once();
  // Cancels the running captures and refuses further job steps.
  void fence(const std::string& why);
  // Ends what this host had taken, joins with a fresh lease, takes work again.
  void rejoin();
  void publish_cameras();
  void sweep();

  FleetStore& fleet_;
  JobStore& store_;
  CameraSet& cameras_;
  FleetRegistry& registry_;
  FleetOptions options_;  // url set by start(), fixed after

  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::chrono::steady_clock::time_point last_renewed_{};  // when the last good renewal began
  std::chrono::steady_clock::time_point fenced_since_{};
  bool fenced_ = false;
  std::string published_;  // the cameras as last published (published again when changed)
  std::thread renewer_, fencer_;
};

}  // namespace camlab::service
