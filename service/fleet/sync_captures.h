// Synchronised captures (POST /v1/sync-captures; service/jobs/sync_schedule.h has the
// schedule and the result): the request is checked against every camera, a capture job is
// submitted for each camera to its host with the common start, and the parent job
// ("sync_capture", run by the host that took the request) waits for them. The cameras are
// a fleet's, or one camlabd's own (sync_capture_site.h). Its progress is
// the sum of theirs; once all have ended it ends with the comparison of their frames'
// start times: succeeded when every camera captured, else failed, naming which did not.
//
// The parent belongs to this host: if the host stops, it ends interrupted (its captures
// run on their own hosts regardless). Cancelling the parent cancels every capture.
//
// Thread-safe: submit() and cancel() from any thread; one thread of its own.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "service/fleet/sync_capture_site.h"
#include "service/store/job_store.h"

namespace camlab::service {

// Limits of a synchronised capture request.
inline constexpr int kMaxSyncCameras = 32;
inline constexpr int64_t kMinSyncStartInMs = 100, kMaxSyncStartInMs = 60000;
inline constexpr int64_t kMaxSyncLateMs = 10000;
// A rig view whose frames start further apart is flagged (the bound for one host).
inline constexpr int64_t kDefaultMaxSkewUs = 1000, kMaxSyncSkewUs = 1000000;

class SyncCaptures {
 public:
  explicit SyncCaptures(SyncCaptureSite& site) : site_(site) {}
  ~SyncCaptures();
  SyncCaptures(const SyncCaptures&) = delete;
  SyncCaptures& operator=(const SyncCaptures&) = delete;

  void start();
  void stop();

  // {"cameras": [ID, ...], "capture": {capture request}, "start_in_ms": 1000,
  //  "max_late_ms": 100, "max_skew_us": 1000} -> the parent job (running). Errors as for a capture
  //  request,
  // per camera ("cameras[2]: ..."), and "invalid_request" for the rest.
  Result<JobRecord> submit(const nlohmann::json& body);
  // Cancels every capture of parent `id` that has not ended; false when `id` is no
  // synchronised capture of this host's.
  bool cancel(int64_t id);

 private:
  struct Parent {
    int64_t start_at_unix_ms = 0;
    int64_t max_skew_us = kDefaultMaxSkewUs;
    std::vector<std::string> cameras;  // fleet ids, in the request's order
    std::vector<int64_t> jobs;         // one capture per camera, same order
    int frames_total = 0;
  };
  void run();
  // Ends the parent when every capture has (true), else updates its progress.
  bool check(int64_t id, const Parent& parent);

  SyncCaptureSite& site_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::map<int64_t, Parent> parents_;  // running, by parent id
  std::thread thread_;
};

}  // namespace camlab::service
