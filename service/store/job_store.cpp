#include "service/store/job_store.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <utility>

#include "base/log.h"
#include "service/store/fleet_store.h"
#include "service/store/store_retry.h"

namespace camlab::service {

namespace {

std::string iso_time(int64_t ms) {
  if (ms <= 0) return "";
  const std::time_t seconds = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<int>(ms % 1000));
  return buffer;
}

}  // namespace

int64_t unix_time_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string dump_json(const nlohmann::json& json) {
  return json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

nlohmann::json parse_stored_json(const std::string& text) {
  if (text.empty()) return nullptr;
  nlohmann::json json = nlohmann::json::parse(text, nullptr, false);
  return json.is_discarded() ? nlohmann::json(nullptr) : json;
}

std::string job_folder_name(const std::string& prefix, int64_t id) {
  if (prefix.empty()) return "";
  char number[32];
  std::snprintf(number, sizeof number, "%06lld", static_cast<long long>(id));
  return prefix + number;
}

const char* job_state_name(JobState state) {
  // A switch, so that the compiler names a state left out; one line each, as a table.
  // clang-format off
  switch (state) {
    case JobState::kQueued: return "queued";
    case JobState::kRunning: return "running";
    case JobState::kSucceeded: return "succeeded";
    case JobState::kFailed: return "failed";
    case JobState::kCancelled: return "cancelled";
    case JobState::kInterrupted: return "interrupted";
    case JobState::kDeviceLost: return "device_lost";
  }
  // clang-format on
  return "failed";
}

std::optional<JobState> parse_job_state(const std::string& name) {
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kSucceeded, JobState::kFailed,
                     JobState::kCancelled, JobState::kInterrupted, JobState::kDeviceLost})
    if (name == job_state_name(s)) return s;
  return std::nullopt;
}

bool is_finished(JobState state) {
  return state != JobState::kQueued && state != JobState::kRunning;
}

nlohmann::json to_json(const JobRecord& job) {
  nlohmann::json json = {
      {"id", job.id},
      {"kind", job.kind},
      {"state", job_state_name(job.state)},
      {"request", job.request},
      {"created_at", iso_time(job.created_ms)},
      {"progress",
       {{"frames_done", job.frames_done},
        {"frames_total", job.frames_total},
        {"frames_discarded", job.frames_discarded},
        {"fraction", job.frames_total > 0 ? static_cast<double>(job.frames_done) / job.frames_total
                                          : (is_finished(job.state) ? 1.0 : 0.0)}}}};
  if (!job.camera_id.empty()) json["camera_id"] = job.camera_id;
  if (!job.host.empty()) json["host"] = job.host;
  if (!job.folder.empty()) json["folder"] = job.folder;
  json["started_at"] =
      job.started_ms ? nlohmann::json(iso_time(job.started_ms)) : nlohmann::json(nullptr);
  json["finished_at"] =
      job.finished_ms ? nlohmann::json(iso_time(job.finished_ms)) : nlohmann::json(nullptr);
  if (!job.error_code.empty())
    json["error"] = {{"code", job.error_code}, {"message", job.error_message}};
  json["result"] = job.result;
  return json;
}

JobStore::JobStore(std::string local_host, StoreRetry retry)
    : local_host_(std::move(local_host)), retry_(retry), op_prefix_(new_operation_prefix()) {}

JobStore::~JobStore() = default;

std::string JobStore::next_op() {
  std::lock_guard lock(mutex_);
  return op_prefix_ + "-" + std::to_string(++op_counter_);
}

template <class Attempt>
auto JobStore::with_retry(Patience patience, Attempt&& attempt) -> decltype(attempt()) {
  const std::chrono::milliseconds budget = patience == Patience::kWorker ? retry_.worker_patience
                                           : patience == Patience::kRequest
                                               ? retry_.request_patience
                                               : std::chrono::milliseconds(0);
  return retry_while_unavailable(budget, mutex_, std::forward<Attempt>(attempt));
}

Result<JobRecord> JobStore::create(const std::string& kind, const std::string& camera_id,
                                   const nlohmann::json& request, const std::string& folder_prefix,
                                   int frames_total) {
  NewJob job{kind, camera_id, dump_json(request), folder_prefix, frames_total, unix_time_ms()};
  const std::string op = next_op();
  return with_retry(Patience::kRequest, [&]() -> Result<JobRecord> {
    Result<JobRecord> created = db_insert_job(job, op);
    if (!created) return created;
    created->request = request;
    notify_change({created->id, JobState::kQueued, 0, frames_total, 0});
    return created;
  });
}

Result<std::optional<JobRecord>> JobStore::get(int64_t id) {
  return with_retry(Patience::kNone, [&]() -> Result<std::optional<JobRecord>> {
    if (auto cached = finished_.find(id); cached != finished_.end())
      return std::optional<JobRecord>(cached->second.job);
    Result<std::optional<JobRecord>> read = db_get_job(id);
    if (!read || !read->has_value()) return read;
    JobRecord& job = **read;
    if (is_finished(job.state)) remember_finished(job);
    show_live(job);
    return read;
  });
}

Result<std::vector<JobRecord>> JobStore::list(std::optional<JobState> state, int limit,
                                              int offset) {
  return with_retry(Patience::kNone, [&]() -> Result<std::vector<JobRecord>> {
    Result<std::vector<JobRecord>> jobs = db_list_jobs(state, limit, offset);
    if (jobs)
      for (JobRecord& job : *jobs) show_live(job);
    return jobs;
  });
}

Result<std::map<std::string, int64_t>> JobStore::count_by_state() {
  return with_retry(Patience::kNone, [&] { return db_count_by_state(); });
}

void JobStore::show_live(JobRecord& job) const {
  if (job.state != JobState::kRunning) return;
  if (auto live = live_.find(job.id); live != live_.end()) {
    job.frames_done = live->second.frames_done;
    job.frames_total = live->second.frames_total;
    job.frames_discarded = live->second.frames_discarded;
  }
}

void JobStore::remember_finished(const JobRecord& job) {
  const size_t bytes = dump_json(job.request).size() + dump_json(job.result).size();
  if (bytes > kFinishedCacheBytes) return;
  // Bounded: the oldest ids give way (status polling is of recent jobs).
  while (!finished_.empty() && (finished_.size() >= kFinishedCacheJobs ||
                                finished_bytes_ + bytes > kFinishedCacheBytes)) {
    if (job.id < finished_.begin()->first) return;
    finished_bytes_ -= finished_.begin()->second.bytes;
    finished_.erase(finished_.begin());
  }
  finished_bytes_ += bytes;
  finished_.emplace(job.id, CachedJob{job, bytes});
}

Result<bool> JobStore::start(int64_t id) {
  const int64_t now_ms = unix_time_ms();
  const std::string op = next_op();
  return with_retry(Patience::kWorker, [&]() -> Result<bool> {
    Result<bool> started = db_start_job(id, now_ms, op);
    if (started && *started) {
      started_here_.insert(id);
      notify_change({id, JobState::kRunning});
    }
    return started;
  });
}

Status JobStore::write_progress(int64_t id, LiveProgress& live) {
  bool running;
  CAMLAB_ASSIGN(running,
                db_write_progress(id, live.frames_done, live.frames_total, live.frames_discarded));
  live.written_frames_done = live.frames_done;
  live.written_ms = unix_time_ms();
  live.dirty = false;
  // Not running (finished meanwhile, or never started): nothing live to show.
  if (!running) live_.erase(id);
  return {};
}

Status JobStore::flush_progress(int64_t id) {
  auto live = live_.find(id);
  if (live == live_.end()) return {};
  if (live->second.dirty)
    if (Status written = write_progress(id, live->second); !written) return written;
  live_.erase(id);
  return {};
}

Status JobStore::progress(int64_t id, int frames_done, int frames_total, int frames_discarded) {
  std::lock_guard lock(mutex_);
  LiveProgress& live = live_[id];
  live.frames_done = frames_done;
  live.frames_total = frames_total;
  live.frames_discarded = frames_discarded;
  live.dirty = true;
  // Only a job this store started is shown running (a report for a job not running is
  // ignored, as the database ignores it).
  if (started_here_.contains(id))
    notify_change({id, JobState::kRunning, frames_done, frames_total, frames_discarded});
  // The first report, the last frame, every kProgressRowFrames frames and every
  // kProgressRowMs go to the database; the rest only to memory (one write a frame was the
  // store mutex's largest holder during a capture). A report that cannot be written
  // stays in memory (dirty) for the next one, or the finish.
  const bool due = live.written_frames_done < 0 || frames_done >= frames_total ||
                   frames_done - live.written_frames_done >= kProgressRowFrames ||
                   unix_time_ms() - live.written_ms >= kProgressRowMs;
  if (!due) return {};
  return write_progress(id, live);
}

Result<bool> JobStore::finish(int64_t id, JobState state, const std::optional<Error>& error,
                              const nlohmann::json& result) {
  const std::string error_code = error ? std::string(name_of(error->code)) : "";
  const std::string error_message = error ? error->message : "";
  // A job without a result stores NULL, which reads back as null.
  const std::optional<std::string> result_text =
      result.is_null() ? std::nullopt : std::optional<std::string>(dump_json(result));
  const int64_t now_ms = unix_time_ms();
  const std::string op = next_op();
  Result<bool> finished = with_retry(Patience::kWorker, [&]() -> Result<bool> {
    // The last progress first, so the finished row holds it.
    if (Status flushed = flush_progress(id); !flushed) return flushed.error();
    Result<bool> finished =
        db_finish_job(id, state, now_ms, error_code, error_message, result_text, op);
    if (!finished) return finished;
    started_here_.erase(id);
    if (*finished) notify_finished(id, state);
    return finished;
  });
  // The fleet ended the job while this host ran on (frozen past its lease, or cut off, its
  // worker kept writing frames until it fenced itself): the frames it kept are on disk, and
  // the database is brought up to them (it said 31 where the folder held 40). Outside the
  // store's lock: the fleet has its own connection and lock.
  if (finished && !*finished && fleet() && result.is_object() && result.contains("frames_kept") &&
      result["frames_kept"].is_number_integer())
    if (Status raised = fleet()->set_recovered_frames(id, result["frames_kept"].get<int>());
        !raised)
      log_warning(log::Category::kJobs, "job %lld: frames kept after the fleet ended it: %s",
                  static_cast<long long>(id), raised.error().message.c_str());
  return finished;
}

void JobStore::notify_finished(int64_t id, JobState state) {
  if (!change_observer_ && !finish_observer_) return;
  Result<FinishedSummary> summary = db_finished_summary(id);
  const FinishedSummary stored = summary ? *summary : FinishedSummary{};
  notify_change({id, state, stored.frames_done, stored.frames_total, stored.frames_discarded});
  if (finish_observer_) finish_observer_(stored.kind, state);
}

Result<bool> JobStore::cancel_queued(int64_t id) {
  const int64_t now_ms = unix_time_ms();
  const std::string op = next_op();
  return with_retry(Patience::kRequest, [&]() -> Result<bool> {
    Result<bool> cancelled = db_cancel_queued(id, now_ms, op);
    if (cancelled && *cancelled) notify_finished(id, JobState::kCancelled);
    return cancelled;
  });
}

Result<int> JobStore::interrupt_unfinished(const std::string& message) {
  return with_retry(Patience::kWorker, [&]() -> Result<int> {
    while (!live_.empty())
      if (Status flushed = flush_progress(live_.begin()->first); !flushed) return flushed.error();
    started_here_.clear();
    return db_interrupt_unfinished(message, unix_time_ms());
  });
}

void JobStore::relay_change(const JobChange& change) {
  std::lock_guard lock(mutex_);
  // Another host changed the job: a copy cached here as finished is stale (a restarted
  // host recovered its frames, 52 where the cache said 31); the next get() reads it anew.
  if (auto cached = finished_.find(change.id); cached != finished_.end()) {
    finished_bytes_ -= cached->second.bytes;
    finished_.erase(cached);
  }
  notify_change(change);
}

Status JobStore::put_latency(const LatencyRecord& record) {
  return with_retry(Patience::kWorker, [&] { return db_put_latency(record); });
}

Result<std::optional<LatencyRecord>> JobStore::latency(const std::string& camera_id) {
  return with_retry(Patience::kNone, [&] { return db_latency(camera_id); });
}

}  // namespace camlab::service
