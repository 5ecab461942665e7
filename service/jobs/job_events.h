// Job changes as they happen, for clients that watch rather than poll (GET /v1/events:
// the dashboard's job list, scripts waiting on a capture's progress). The job store's
// change observer publishes here; each subscriber receives batches of the changes since
// its last batch, coalesced per job (the latest change of each job, in the order the jobs
// first changed), at most every kMinBatchInterval, and an empty batch after kHeartbeat
// without a change, so a connection whose client left is noticed.
//
// A subscriber that falls kMaxPendingJobs jobs behind gets a batch marked `resync` (its
// pending changes dropped): it should read the job list again.
//
// Thread-safe. publish() only records and wakes (the store calls it under its lock); the
// hub's thread delivers, calling each subscriber's callback, which must be quick.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "base/result.h"
#include "service/store/job_store.h"

namespace camlab::service {

struct JobEventBatch {
  std::vector<JobChange> changes;  // empty: a heartbeat
  bool resync = false;             // changes were dropped: read the job list again
};

class JobEvents {
 public:
  static constexpr std::chrono::milliseconds kMinBatchInterval{100};
  static constexpr std::chrono::seconds kHeartbeat{15};
  static constexpr size_t kMaxPendingJobs = 1024;
  static constexpr int kMaxSubscribers = 64;

  class Subscription;
  using Deliver = std::function<void(Result<JobEventBatch>)>;

  JobEvents() = default;
  ~JobEvents();
  JobEvents(const JobEvents&) = delete;
  JobEvents& operator=(const JobEvents&) = delete;

  void start();
  // Ends every subscription with "shutting_down" and joins the thread.
  void stop();

  // From the job store's change observer.
  void publish(const JobChange& change);

  // "too_many_connections" beyond kMaxSubscribers; "shutting_down" once stopping.
  Result<std::shared_ptr<Subscription>> subscribe();

 private:
  struct Subscriber {
    std::vector<JobChange> pending;  // one per job, in the order the jobs first changed
    bool resync = false;
    Deliver deliver;  // empty: not asking
    std::chrono::steady_clock::time_point last_delivery{};
    bool closed = false;
  };

  void run();
  void unsubscribe(const std::shared_ptr<Subscriber>& subscriber);

  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool started_ = false;
  std::list<std::shared_ptr<Subscriber>> subscribers_;
  std::thread thread_;
};

class JobEvents::Subscription {
 public:
  Subscription(JobEvents* events, std::shared_ptr<Subscriber> subscriber)
      : events_(events), subscriber_(std::move(subscriber)) {}
  ~Subscription() { close(); }
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;

  // Asks for the next batch: `deliver` is called once, on the hub's thread, with a batch or
  // with "shutting_down".
  void next(Deliver deliver);
  // Leaves: a pending request is dropped. Idempotent.
  void close();

 private:
  JobEvents* events_;
  std::shared_ptr<Subscriber> subscriber_;
};

}  // namespace camlab::service
