#include "service/fleet/sync_captures.h"

#include <set>

#include "base/log.h"
#include "service/jobs/sync_schedule.h"

namespace camlab::service {

namespace {

// How often the parents' captures are looked at.
constexpr std::chrono::milliseconds kCheckEvery{100};

Result<int64_t> integer_field(const nlohmann::json& body, const char* name, int64_t fallback,
                              int64_t low, int64_t high, const char* unit) {
  if (!body.contains(name)) return fallback;
  const nlohmann::json& value = body[name];
  if (!value.is_number_integer() || value.get<int64_t>() < low || value.get<int64_t>() > high)
    return make_error("invalid_request", std::string(name) + " must be an integer in [" +
                                             std::to_string(low) + ", " + std::to_string(high) +
                                             "] " + unit);
  return value.get<int64_t>();
}

}  // namespace

SyncCaptures::~SyncCaptures() { stop(); }

void SyncCaptures::start() {
  thread_ = std::thread([this] { run(); });
}

void SyncCaptures::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

Result<JobRecord> SyncCaptures::submit(const nlohmann::json& body) {
  static const std::set<std::string> kFields = {"cameras", "capture", "start_in_ms", "max_late_ms",
                                                "max_skew_us"};
  for (const auto& [key, value] : body.items())
    if (!kFields.contains(key))
      return make_error("invalid_request",
                        "unknown field '" + key.substr(0, 100) +
                            "' (allowed: cameras, capture, start_in_ms, max_late_ms, max_skew_us)");
  if (!body.contains("cameras") || !body["cameras"].is_array() || body["cameras"].empty() ||
      body["cameras"].size() > static_cast<size_t>(kMaxSyncCameras))
    return make_error("invalid_request",
                      "cameras must be a list of 1 to " + std::to_string(kMaxSyncCameras) +
                          " camera ids (GET /v1/cameras; CAMERA@HOST in a fleet, GET /v1/fleet)");
  if (!body.contains("capture") || !body["capture"].is_object())
    return make_error("invalid_request",
                      "capture must be a capture request, e.g. {\"kind\": \"single\"}");
  int64_t start_in_ms, max_late_ms;
  CAMLAB_ASSIGN(start_in_ms, integer_field(body, "start_in_ms", 1000, kMinSyncStartInMs,
                                           kMaxSyncStartInMs, "ms"));
  CAMLAB_ASSIGN(max_late_ms, integer_field(body, "max_late_ms", 100, 0, kMaxSyncLateMs, "ms"));
  int64_t max_skew_us;
  CAMLAB_ASSIGN(max_skew_us,
                integer_field(body, "max_skew_us", kDefaultMaxSkewUs, 0, kMaxSyncSkewUs, "us"));

  // Every camera checked before anything is stored: a bad request stores nothing.
  std::vector<CameraTarget> targets;
  std::vector<int> frames;
  std::set<std::string> seen;
  for (size_t i = 0; i < body["cameras"].size(); ++i) {
    const std::string where = "cameras[" + std::to_string(i) + "]: ";
    const nlohmann::json& id = body["cameras"][i];
    if (!id.is_string()) return make_error("invalid_request", where + "a camera id is a string");
    auto target = site_.resolve(id.get<std::string>());
    if (!target) return target.error().with_context(where);
    if (!seen.insert(target->fleet_id()).second)
      return make_error("invalid_request", where + target->fleet_id() + " is listed twice");
    auto plan = site_.plan(*target, body["capture"]);
    if (!plan) return plan.error().with_context(where);
    if (!target->available)
      return make_error("no_device", where + "camera " + target->fleet_id() +
                                         " is not available: " + target->unavailable_reason);
    frames.push_back(plan->total_frames());
    targets.push_back(std::move(*target));
  }

  Parent parent;
  parent.start_at_unix_ms = unix_time_ms() + start_in_ms;
  parent.max_skew_us = max_skew_us;
  nlohmann::json capture = body["capture"];
  capture["schedule"] = {{"start_at_unix_ms", parent.start_at_unix_ms},
                         {"max_late_ms", max_late_ms}};
  auto undo = [&](const Error& error) -> Error {
    for (int64_t job : parent.jobs) (void)site_.jobs().cancel_queued(job);
    return error;
  };
  for (size_t i = 0; i < targets.size(); ++i) {
    auto job = site_.submit(targets[i], "capture", capture, frames[i]);
    if (!job) return undo(job.error().with_context("cameras[" + std::to_string(i) + "]: "));
    parent.jobs.push_back(job->id);
    parent.cameras.push_back(targets[i].fleet_id());
    parent.frames_total += frames[i];
  }
  const nlohmann::json request = {
      {"cameras", parent.cameras},  {"capture", body["capture"]},
      {"start_in_ms", start_in_ms}, {"max_late_ms", max_late_ms},
      {"max_skew_us", max_skew_us}, {"start_at_unix_ms", parent.start_at_unix_ms},
      {"jobs", parent.jobs}};
  auto created = site_.jobs().create("sync_capture", "", request, "", parent.frames_total);
  if (!created) return undo(created.error());
  if (auto started = site_.jobs().start(created->id); !started || !*started)
    return undo(started ? make_error("internal", "the synchronised capture did not start")
                        : started.error());
  {
    std::lock_guard lock(mutex_);
    parents_.emplace(created->id, parent);
  }
  wake_.notify_all();
  log_info(log::Category::kJobs, "job %lld: synchronised capture of %zu cameras at %lld",
           static_cast<long long>(created->id), parent.jobs.size(),
           static_cast<long long>(parent.start_at_unix_ms));
  auto now = site_.jobs().get(created->id);
  return now && now->has_value() ? **now : *created;
}

bool SyncCaptures::cancel(int64_t id) {
  std::vector<int64_t> jobs;
  {
    std::lock_guard lock(mutex_);
    if (auto it = parents_.find(id); it != parents_.end()) jobs = it->second.jobs;
  }
  // Another host's: its record lists the captures (the host that took it ends it once
  // they have ended).
  if (jobs.empty()) {
    auto record = site_.jobs().get(id);
    if (!record || !record->has_value()) return false;
    const JobRecord& parent = **record;
    if (parent.kind != "sync_capture" || parent.state != JobState::kRunning ||
        !parent.request.is_object() || !parent.request.contains("jobs") ||
        !parent.request["jobs"].is_array())
      return false;
    for (const nlohmann::json& job : parent.request["jobs"])
      if (job.is_number_integer()) jobs.push_back(job.get<int64_t>());
    if (jobs.empty()) return false;
  }
  for (int64_t job : jobs) {
    auto cancelled = site_.jobs().cancel_queued(job);
    if (cancelled && *cancelled) continue;
    auto record = site_.jobs().get(job);
    if (!record || !record->has_value() || (*record)->state != JobState::kRunning) continue;
    // Running, here or on another host.
    site_.cancel_running(job);
  }
  return true;
}

void SyncCaptures::run() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, kCheckEvery);
    const std::map<int64_t, Parent> parents = parents_;
    lock.unlock();
    std::vector<int64_t> ended;
    for (const auto& [id, parent] : parents)
      if (check(id, parent)) ended.push_back(id);
    lock.lock();
    for (int64_t id : ended) parents_.erase(id);
  }
}

bool SyncCaptures::check(int64_t id, const Parent& parent) {
  std::vector<JobRecord> children;
  int frames_done = 0, frames_discarded = 0;
  bool all_ended = true;
  for (int64_t job : parent.jobs) {
    auto record = site_.jobs().get(job);
    if (!record || !record->has_value()) return false;  // the database is away: next time
    frames_done += (*record)->frames_done;
    frames_discarded += (*record)->frames_discarded;
    all_ended = all_ended && is_finished((*record)->state);
    children.push_back(**record);
  }
  if (!all_ended) {
    (void)site_.jobs().progress(id, frames_done, parent.frames_total, frames_discarded);
    return false;
  }
  std::map<std::string, HostClock> clocks;
  for (const auto& [name, clock] : site_.clocks())
    for (const JobRecord& child : children)
      if (child.host == name) clocks[name] = clock;
  const nlohmann::json result = summarize_sync_capture(parent.start_at_unix_ms, parent.cameras,
                                                       children, clocks, parent.max_skew_us);
  // Failed: the first camera's that did not capture gives the code, each says why.
  std::string failed;
  ErrorCode code = ErrorCode::kConflict;
  for (size_t i = 0; i < children.size(); ++i) {
    if (children[i].state == JobState::kSucceeded) continue;
    if (failed.empty())
      code = find_error_code(children[i].error_code).value_or(ErrorCode::kConflict);
    failed += (failed.empty() ? "" : "; ") + parent.cameras[i] + " " +
              job_state_name(children[i].state) +
              (children[i].error_message.empty() ? "" : " (" + children[i].error_message + ")");
  }
  (void)site_.jobs().progress(id, frames_done, parent.frames_total, frames_discarded);
  const std::optional<Error> error =
      failed.empty() ? std::nullopt
                     : std::optional<Error>(
                           Error(code, "not every camera captured at the common start: " + failed));
  auto finished = site_.jobs().finish(id, failed.empty() ? JobState::kSucceeded : JobState::kFailed,
                                      error, result);
  if (!finished)
    log_warning(log::Category::kJobs, "job %lld: %s", static_cast<long long>(id),
                finished.error().message.c_str());
  return finished.ok();
}

}  // namespace camlab::service
