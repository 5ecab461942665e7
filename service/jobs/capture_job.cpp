#include "service/jobs/capture_job.h"

#include <algorithm>

#include "base/log.h"
#include "capture/capture_plan.h"
#include "capture/capture_runner.h"
#include "capture/latency_probe.h"
#include "service/jobs/sync_schedule.h"
#include "service/metrics.h"

namespace camlab::service {

namespace {

// Records a probe (or the fallback) for the camera and returns the latency to use.
struct LatencyChoice {
  int frames = 0;
  int min_frames = -1;  // when the probe and the spec disagree: the smaller (runner option)
  std::string source;
  nlohmann::json details;
};

Result<LatencyChoice> measure_latency(device::Camera& camera, const CaptureJobEnv& env,
                                      int* frames_consumed) {
  const std::string& id = camera.identity().id;
  int probe_frames = 0;
  auto probe = capture::probe_control_latency(camera, 3, 8, env.cancel, &probe_frames);
  // Counted whether the probe succeeded or not: a failed probe consumed frames too.
  *frames_consumed += probe_frames;
  LatencyChoice choice;
  if (probe) {
    choice.frames = probe->latency_frames;
    choice.source = "probe";
    choice.details = {{"probed_frames", probe->latency_frames},
                      {"repetitions", probe->repetitions},
                      {"agreeing", probe->agreeing},
                      {"frames_consumed", probe->frames_consumed},
                      {"mean_dn_trace", probe->mean_dn_trace}};
    if (env.spec_latency_frames) {
      choice.details["spec_frames"] = *env.spec_latency_frames;
      // Keeping a frame too early breaks the settings-in-effect promise; one too late
      // only costs a frame: use the larger.
      if (*env.spec_latency_frames > choice.frames) {
        choice.min_frames = choice.frames;
        choice.frames = *env.spec_latency_frames;
        choice.source = "spec";
      }
    }
  } else if (is_device_error(probe.error().code) || probe.error().code == ErrorCode::kCancelled) {
    return probe.error();
  } else if (env.spec_latency_frames) {
    choice.frames = *env.spec_latency_frames;
    choice.source = "spec";
    choice.details = {
        {"probe_error", {{"code", probe.error().code}, {"message", probe.error().message}}},
        {"spec_frames", *env.spec_latency_frames},
        {"frames_consumed", probe_frames}};
    log_warning(log::Category::kCameras,
                "camera %s: latency probe failed (%s); using the spec's %d frames", id.c_str(),
                probe.error().message.c_str(), *env.spec_latency_frames);
  } else {
    // Not stored: a later probe (another scene, more light) may succeed.
    choice.frames = kFallbackLatencyFrames;
    choice.source = "default";
    choice.details = {
        {"probe_error", {{"code", probe.error().code}, {"message", probe.error().message}}}};
    log_warning(log::Category::kCameras, "camera %s: latency probe failed (%s); assuming %d frames",
                id.c_str(), probe.error().message.c_str(), kFallbackLatencyFrames);
    return choice;
  }
  LatencyRecord record{id, choice.frames, choice.source, unix_time_ms(), choice.details};
  if (auto s = env.store.put_latency(record); !s)
    log_warning(log::Category::kCameras, "camera %s: %s", id.c_str(), s.error().message.c_str());
  log_info(log::Category::kCameras, "camera %s: control latency %d frames (%s)", id.c_str(),
           choice.frames, choice.source.c_str());
  return choice;
}

}  // namespace

Status probe_and_store_latency(device::Camera& camera, const CaptureJobEnv& env,
                               int* frames_consumed) {
  auto choice = measure_latency(camera, env, frames_consumed);
  if (!choice) return choice.error();
  return {};
}

namespace {

Result<LatencyChoice> latency_for(device::Camera& camera, const CaptureJobEnv& env,
                                  int* frames_consumed) {
  auto stored = env.store.latency(camera.identity().id);
  if (stored && stored->has_value()) {
    LatencyChoice choice{(*stored)->latency_frames, -1, (*stored)->source, nullptr};
    const nlohmann::json& details = (*stored)->details;
    if (details.is_object() && details.contains("probed_frames") &&
        details["probed_frames"].is_number_integer() &&
        details["probed_frames"].get<int>() < choice.frames)
      choice.min_frames = details["probed_frames"].get<int>();
    return choice;
  }
  return measure_latency(camera, env, frames_consumed);
}

// Writes progress to the store and counts frames, on each frame the runner keeps (and
// notes its start time for a synchronised capture).
class ProgressObserver final : public capture::CaptureObserver {
 public:
  ProgressObserver(int64_t job_id, const CaptureJobEnv& env, FrameStartLog* starts)
      : job_id_(job_id), env_(env), starts_(starts) {}
  void on_frame(const image::CaptureFrameEntry& entry, const image::FrameSidecar& sidecar,
                const capture::CaptureProgress& progress) override {
    env_.metrics.count_frames(1, sidecar.frames_discarded);
    if (starts_) starts_->add(entry.index, sidecar);
    (void)env_.store.progress(job_id_, progress.frames_kept, progress.frames_total,
                              progress.frames_discarded);
  }

 private:
  int64_t job_id_;
  const CaptureJobEnv& env_;
  FrameStartLog* starts_;
};

// Frames lost by the camera and by camlabd, apart, and a warning when camlabd could not
// keep up (docs/capture-api.md, "Frames lost, and whose they were").
void add_frame_loss(const capture::CaptureSummary& summary, nlohmann::json* result) {
  (*result)["frames_dropped_by_device"] = summary.frames_dropped_by_device;
  (*result)["frames_dropped_by_camlabd"] = summary.frames_dropped_by_camlab;
  (*result)["frames_refused_by_writer"] = summary.frames_refused_by_writer;
  (*result)["writer"] = {{"most_frames_queued", summary.writer.most_frames_held},
                         {"most_bytes_queued", summary.writer.most_bytes_held},
                         {"commits", summary.writer.commits}};
  nlohmann::json warnings = nlohmann::json::array();
  if (summary.frames_dropped_by_camlab > 0)
    warnings.push_back(
        "camlabd could not keep up with the camera: " +
        std::to_string(summary.frames_dropped_by_camlab) + " frames lost (" +
        std::to_string(summary.frames_refused_by_writer) +
        " because the disk was slower than the camera, the rest while camlabd held every "
        "buffer); the steps they cost were taken again");
  if (summary.frames_dropped_by_device > 0)
    warnings.push_back("the camera dropped " + std::to_string(summary.frames_dropped_by_device) +
                       " frames (it did not deliver every frame at its frame interval); the "
                       "steps they cost were taken again");
  if (!warnings.empty()) (*result)["warnings"] = std::move(warnings);
}

JobOutcome failed(Error error, bool device_failed = false) {
  JobOutcome outcome;
  outcome.state = JobState::kFailed;
  outcome.device_failed = device_failed || is_device_error(error.code);
  outcome.failure_detail = error.message;
  outcome.error = std::move(error);
  return outcome;
}

// A cancel before any frame was taken (during the latency probe, or waiting for a
// synchronised start): cancelled by the user, or interrupted by shutdown (the worker makes
// it device_lost when the camera is gone).
JobOutcome stopped_early(const CaptureJobEnv& env,
                         const std::string& during = "the latency probe") {
  const bool shutdown = env.shutting_down && env.shutting_down->load();
  JobOutcome outcome;
  outcome.state = shutdown ? JobState::kInterrupted : JobState::kCancelled;
  outcome.error = shutdown ? make_error("interrupted", "camlabd stopped during " + during)
                           : make_error("cancelled", "cancelled by request during " + during);
  outcome.failure_detail = "cancelled during " + during;
  return outcome;
}

}  // namespace

bool is_device_error(ErrorCode code) {
  return code == ErrorCode::kNoDevice || code == ErrorCode::kIoError ||
         code == ErrorCode::kTimeout || code == ErrorCode::kNotStreaming ||
         code == ErrorCode::kBusy;
}

JobOutcome execute_capture(device::Camera& camera, const JobRecord& job, const CaptureJobEnv& env) {
  // Plan again against the camera as it is now (controls may have changed since POST).
  auto controls = camera.controls();
  if (!controls) return failed(controls.error());
  auto formats = camera.formats();
  if (!formats) return failed(formats.error());
  // A synchronised capture's schedule is the job's, not the plan's.
  nlohmann::json request = job.request;
  auto schedule = take_schedule(&request);
  if (!schedule) return failed(schedule.error());
  auto plan = capture::plan_capture(request, *controls, *formats, env.traits);
  if (!plan) return failed(plan.error());

  int probe_frames = 0;
  auto latency = latency_for(camera, env, &probe_frames);
  if (!latency && latency.error().code == ErrorCode::kCancelled) return stopped_early(env);
  if (!latency) return failed(latency.error(), true);
  // Everything that takes time is done: wait for the common start.
  int64_t late_us = 0;
  if (*schedule) {
    auto waited = wait_for_start(
        **schedule, env.cancel,
        why_late(**schedule, probe_frames, env.previous_work, env.previous_work_ended_unix_ms));
    if (!waited && waited.error().code == ErrorCode::kCancelled)
      return stopped_early(env, "the wait for the synchronised start");
    if (!waited) return failed(waited.error());
    late_us = *waited;
  }
  FrameStartLog starts;

  capture::CaptureOptions options;
  options.control_latency_frames = latency->frames;
  options.control_latency_min_frames = latency->min_frames;
  options.frame_timeout = env.frame_timeout;
  options.cancel = env.cancel;
  options.frame_tap = env.frame_tap;
  options.source = env.source;
  options.source["job_id"] = job.id;
  options.source["control_latency"] = {{"frames", latency->frames}, {"source", latency->source}};
  ProgressObserver observer(job.id, env, *schedule ? &starts : nullptr);
  auto summary = capture::run_capture(camera, *plan, env.data_dir / job.folder, options, &observer);
  if (!summary) return failed(summary.error());

  JobOutcome outcome;
  outcome.result = {
      {"frames_kept", summary->frames_kept},       {"frames_discarded", summary->frames_discarded},
      {"frames_dropped", summary->frames_dropped}, {"frames_consumed", summary->frames_consumed},
      {"frames_minimum", summary->frames_minimum}, {"steps_retaken", summary->steps_retaken},
      {"frames_consumed_by_probe", probe_frames},  {"frames_total", plan->total_frames()},
      {"wall_seconds", summary->wall_seconds},     {"control_latency_frames", latency->frames},
      {"control_latency_source", latency->source}, {"folder", job.folder}};
  add_frame_loss(*summary, &outcome.result);
  if (*schedule) outcome.result["synchronised"] = starts.to_json(**schedule, late_us);
  if (summary->restore_error)
    outcome.result["restore_error"] = {{"code", summary->restore_error->code},
                                       {"message", summary->restore_error->message}};
  (void)env.store.progress(job.id, summary->frames_kept, plan->total_frames(),
                           summary->frames_discarded);
  if (summary->failure) {
    outcome.state = JobState::kFailed;
    outcome.device_failed = is_device_error(summary->failure->code);
    outcome.failure_detail = summary->failure->message;
    outcome.error =
        make_error(summary->failure->code, summary->failure->message + " (the " +
                                               std::to_string(summary->frames_kept) +
                                               " frames captured before the failure are kept)");
  } else if (summary->cancelled) {
    const bool shutdown = env.shutting_down && env.shutting_down->load();
    outcome.state = shutdown ? JobState::kInterrupted : JobState::kCancelled;
    outcome.error =
        shutdown ? make_error("interrupted", "camlabd stopped during the capture; frames kept")
                 : make_error("cancelled", "cancelled by request; frames kept");
  } else {
    outcome.state = JobState::kSucceeded;
  }
  return outcome;
}

JobOutcome execute_latency_probe(device::Camera& camera, const JobRecord&,
                                 const CaptureJobEnv& env) {
  int frames = 0;
  auto latency = measure_latency(camera, env, &frames);
  if (!latency && latency.error().code == ErrorCode::kCancelled) return stopped_early(env);
  if (!latency) return failed(latency.error());
  JobOutcome outcome;
  outcome.state = JobState::kSucceeded;
  outcome.result = {{"control_latency_frames", latency->frames},
                    {"source", latency->source},
                    {"details", latency->details},
                    {"frames_consumed", frames}};
  return outcome;
}

}  // namespace camlab::service
