// Synchronised capture (docs/capture-api.md, "Synchronised capture"): one job over cameras
// on several hosts that start at a common time. The job is a parent ("sync_capture") and a
// capture job per camera; each capture's request carries the schedule:
//
//   "schedule": {"start_at_unix_ms": 1718000000000, "max_late_ms": 100}
//
// The camera's worker plans the capture and finds its latency first, then waits until its
// own clock (CLOCK_REALTIME) reaches the start and runs it; a capture that could only begin
// later than max_late_ms (its camera was busy) fails "busy" without a frame. It records
// each kept frame's start of exposure as Unix time: the frame's monotonic timestamp plus
// the offset between the realtime and monotonic clocks read just before the run.
//
// The parent's result compares the cameras frame by frame: the skew of frame k is the
// spread (latest minus earliest) of the k-th kept frames' start times over the cameras that
// kept one, each on its host's clock; each host's clock offset to the database server (its
// lease renewals measure it) says how far those clocks are apart.
//
// Reentrant, but for wait_for_start, which blocks the calling (worker) thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "image/capture_folder.h"
#include "service/store/job_store.h"

namespace camlab::service {

struct CaptureSchedule {
  int64_t start_at_unix_ms = 0;
  int64_t max_late_ms = 100;
};

// Takes "schedule" out of a capture request (what remains is what plan_capture reads);
// nullopt when there is none, "invalid_request" when it is malformed.
Result<std::optional<CaptureSchedule>> take_schedule(nlohmann::json* request);

// Blocks until CLOCK_REALTIME reaches the start, checking `cancel` at least every 20 ms.
// Returns how late the start was met (us, >= 0); "busy" when it is already later than
// max_late_ms, its message ending in `why_late` (what kept the camera, as the caller
// knows it); "cancelled" when cancelled meanwhile.
Result<int64_t> wait_for_start(const CaptureSchedule& schedule, const std::atomic<bool>* cancel,
                               const std::string& why_late);

// Why a capture could begin only after its synchronised start, for wait_for_start: its own
// latency probe when it ran one (`probe_frames` > 0), else the worker's previous work when
// that ended after the start, else a late pick-up of the job itself.
std::string why_late(const CaptureSchedule& schedule, int probe_frames,
                     const std::string& previous_work, int64_t previous_work_ended_unix_ms);

// The kept frames' start times, as the capture runs. Thread-compatible (the worker).
class FrameStartLog {
 public:
  // Reads the realtime - monotonic offset now: call just before the run.
  FrameStartLog();
  void add(int index, const image::FrameSidecar& sidecar);
  // {"start_at_unix_ms", "late_us", "frames": [{index, sequence, start_unix_us}],
  //  "frame_interval_us"}; start_unix_us is null for a frame whose timestamp is not
  // monotonic (it cannot be placed in Unix time).
  nlohmann::json to_json(const CaptureSchedule& schedule, int64_t late_us) const;

 private:
  struct Frame {
    int index = 0;
    uint64_t sequence = 0;
    std::optional<int64_t> start_unix_us;
  };
  int64_t realtime_minus_monotonic_ns_ = 0;
  std::vector<Frame> frames_;
};

// A host's clock against the database server's (FleetHost).
struct HostClock {
  int64_t offset_us = 0, uncertainty_us = 0;
};

// The parent's result from its children (its "rig_views": the frames grouped by start
// time, service/jobs/rig_views.h, each view's skew against `max_skew_us`) (in the order of the
// request's cameras, each with the fleet camera id it was asked by) and the hosts' clocks.
nlohmann::json summarize_sync_capture(int64_t start_at_unix_ms,
                                      const std::vector<std::string>& cameras,
                                      const std::vector<JobRecord>& children,
                                      const std::map<std::string, HostClock>& clocks,
                                      int64_t max_skew_us = 1000);

}  // namespace camlab::service
