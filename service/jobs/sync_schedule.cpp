#include "service/jobs/sync_schedule.h"

#include <time.h>

#include <algorithm>
#include <cerrno>

#include "service/jobs/rig_views.h"

namespace camlab::service {

namespace {

int64_t clock_ns(clockid_t clock) {
  timespec now{};
  clock_gettime(clock, &now);
  return static_cast<int64_t>(now.tv_sec) * 1000000000 + now.tv_nsec;
}

int64_t median(std::vector<int64_t> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

Result<std::optional<CaptureSchedule>> take_schedule(nlohmann::json* request) {
  if (!request->is_object() || !request->contains("schedule"))
    return std::optional<CaptureSchedule>();
  const nlohmann::json schedule = (*request)["schedule"];
  request->erase("schedule");
  if (!schedule.is_object() || !schedule.contains("start_at_unix_ms") ||
      !schedule["start_at_unix_ms"].is_number_integer())
    return make_error("invalid_request",
                      "schedule must be {\"start_at_unix_ms\": INTEGER, \"max_late_ms\": INTEGER}");
  CaptureSchedule parsed;
  parsed.start_at_unix_ms = schedule["start_at_unix_ms"].get<int64_t>();
  if (schedule.contains("max_late_ms")) {
    if (!schedule["max_late_ms"].is_number_integer() || schedule["max_late_ms"].get<int64_t>() < 0)
      return make_error("invalid_request", "schedule.max_late_ms must be an integer >= 0 (ms)");
    parsed.max_late_ms = schedule["max_late_ms"].get<int64_t>();
  }
  return std::optional<CaptureSchedule>(parsed);
}

std::string why_late(const CaptureSchedule& schedule, int probe_frames,
                     const std::string& previous_work, int64_t previous_work_ended_unix_ms) {
  if (probe_frames > 0)
    return "it measured its control latency first (" + std::to_string(probe_frames) +
           " frames; once per camera, then kept)";
  if (!previous_work.empty() && previous_work_ended_unix_ms > schedule.start_at_unix_ms)
    return "it was busy until " +
           std::to_string(previous_work_ended_unix_ms - schedule.start_at_unix_ms) +
           " ms after the start with " + previous_work;
  return "the job reached the camera late (a loaded host or a long queue)";
}

Result<int64_t> wait_for_start(const CaptureSchedule& schedule, const std::atomic<bool>* cancel,
                               const std::string& why_late) {
  const int64_t start_ns = schedule.start_at_unix_ms * 1000000;
  const int64_t late_ns = clock_ns(CLOCK_REALTIME) - start_ns;
  if (late_ns > schedule.max_late_ms * 1000000)
    return make_error("busy", "the camera could begin only " + std::to_string(late_ns / 1000000) +
                                  " ms after the synchronised start (allowed: " +
                                  std::to_string(schedule.max_late_ms) + " ms): " + why_late);
  // Slices of at most 20 ms, so a cancel is seen; the last one to the start itself, on the
  // realtime clock (absolute, so a slice that begins late does not end late).
  for (;;) {
    if (cancel && cancel->load()) return make_error("cancelled", "cancelled before the start");
    const int64_t now_ns = clock_ns(CLOCK_REALTIME);
    if (now_ns >= start_ns) return (now_ns - start_ns) / 1000;
    const int64_t wake_ns = std::min(start_ns, now_ns + 20000000);
    const timespec wake{static_cast<time_t>(wake_ns / 1000000000),
                        static_cast<long>(wake_ns % 1000000000)};
    while (clock_nanosleep(CLOCK_REALTIME, TIMER_ABSTIME, &wake, nullptr) == EINTR) {
    }
  }
}

FrameStartLog::FrameStartLog()
    : realtime_minus_monotonic_ns_(clock_ns(CLOCK_REALTIME) - clock_ns(CLOCK_MONOTONIC)) {}

void FrameStartLog::add(int index, const image::FrameSidecar& sidecar) {
  Frame frame{index, sidecar.sequence, std::nullopt};
  if (sidecar.clock == "monotonic" && sidecar.timestamp_ns > 0)
    frame.start_unix_us = (sidecar.timestamp_ns + realtime_minus_monotonic_ns_) / 1000;
  frames_.push_back(frame);
}

nlohmann::json FrameStartLog::to_json(const CaptureSchedule& schedule, int64_t late_us) const {
  nlohmann::json frames = nlohmann::json::array();
  std::vector<Frame> sorted = frames_;
  std::sort(sorted.begin(), sorted.end(),
            [](const Frame& a, const Frame& b) { return a.index < b.index; });
  // The frame interval from the frames themselves: time over sequence numbers between
  // consecutive kept frames.
  std::vector<int64_t> intervals_us;
  for (size_t i = 0; i < sorted.size(); ++i) {
    const Frame& f = sorted[i];
    frames.push_back({{"index", f.index},
                      {"sequence", f.sequence},
                      {"start_unix_us", f.start_unix_us ? nlohmann::json(*f.start_unix_us)
                                                        : nlohmann::json(nullptr)}});
    if (i > 0 && f.start_unix_us && sorted[i - 1].start_unix_us &&
        f.sequence > sorted[i - 1].sequence)
      intervals_us.push_back((*f.start_unix_us - *sorted[i - 1].start_unix_us) /
                             static_cast<int64_t>(f.sequence - sorted[i - 1].sequence));
  }
  return {{"start_at_unix_ms", schedule.start_at_unix_ms},
          {"late_us", late_us},
          {"frame_interval_us",
           intervals_us.empty() ? nlohmann::json(nullptr) : nlohmann::json(median(intervals_us))},
          {"frames", frames}};
}

nlohmann::json summarize_sync_capture(int64_t start_at_unix_ms,
                                      const std::vector<std::string>& cameras,
                                      const std::vector<JobRecord>& children,
                                      const std::map<std::string, HostClock>& clocks,
                                      int64_t max_skew_us) {
  nlohmann::json per_camera = nlohmann::json::array();
  std::vector<FrameStart> frame_starts;
  std::vector<int64_t> intervals_us;
  for (size_t c = 0; c < children.size(); ++c) {
    const JobRecord& child = children[c];
    const nlohmann::json sync = child.result.is_object()
                                    ? child.result.value("synchronised", nlohmann::json())
                                    : nlohmann::json();
    nlohmann::json frames = nlohmann::json::array();
    if (sync.is_object()) {
      int k = 0;
      for (const nlohmann::json& frame : sync.value("frames", nlohmann::json::array())) {
        nlohmann::json entry = frame;
        if (frame["start_unix_us"].is_number_integer()) {
          const int64_t start_us = frame["start_unix_us"].get<int64_t>();
          entry["after_start_us"] = start_us - start_at_unix_ms * 1000;
          // The view names the frame by its index in the capture folder (frame_NNNNNN).
          frame_starts.push_back({static_cast<int>(c), frame.value("index", k), start_us});
        }
        frames.push_back(entry);
        ++k;
      }
      if (sync["frame_interval_us"].is_number_integer())
        intervals_us.push_back(sync["frame_interval_us"].get<int64_t>());
    }
    nlohmann::json camera = {{"camera", c < cameras.size() ? cameras[c] : child.camera_id},
                             {"job", child.id},
                             {"host", child.host},
                             {"state", job_state_name(child.state)},
                             {"frames", frames}};
    if (sync.is_object()) camera["late_us"] = sync.value("late_us", int64_t{0});
    if (!child.error_code.empty())
      camera["error"] = {{"code", child.error_code}, {"message", child.error_message}};
    per_camera.push_back(std::move(camera));
  }
  const int64_t interval_us = median(intervals_us);
  // The skew of each trigger, from the rig views (frames grouped by start time): pairing the
  // cameras' k-th frames instead would give a whole interval to every frame of a camera
  // that began a tick later or dropped one, although its frames met the others' triggers.
  const std::vector<RigView> views =
      group_rig_views(std::move(frame_starts), static_cast<int>(children.size()), interval_us);
  nlohmann::json per_view = nlohmann::json::array();
  int64_t worst_us = -1;
  for (const RigView& view : views) {
    const auto cameras_in_view = std::count_if(view.frames.begin(), view.frames.end(),
                                               [](const auto& f) { return f.has_value(); });
    if (cameras_in_view < 2) {
      per_view.push_back(nullptr);  // one camera alone has no skew
      continue;
    }
    per_view.push_back(view.skew_us);
    worst_us = std::max(worst_us, view.skew_us);
  }
  nlohmann::json host_clocks = nlohmann::json::array();
  for (const auto& [host, clock] : clocks)
    host_clocks.push_back({{"host", host},
                           {"offset_to_database_us", clock.offset_us},
                           {"uncertainty_us", clock.uncertainty_us}});
  return {{"start_at_unix_ms", start_at_unix_ms},
          {"cameras", per_camera},
          {"skew_us",
           {{"per_view", per_view},
            {"first_view", per_view.empty() ? nlohmann::json(nullptr) : per_view[0]},
            {"max", worst_us >= 0 ? nlohmann::json(worst_us) : nlohmann::json(nullptr)}}},
          {"frame_interval_us", interval_us > 0 ? nlohmann::json(interval_us) : nullptr},
          {"skew_frames", worst_us >= 0 && interval_us > 0
                              ? nlohmann::json(static_cast<double>(worst_us) / interval_us)
                              : nlohmann::json(nullptr)},
          {"rig_views", rig_views_json(views, max_skew_us)},
          {"host_clocks", host_clocks}};
}

}  // namespace camlab::service
