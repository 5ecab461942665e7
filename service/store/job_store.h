// The job store: every job (capture, latency probe, calibration, analysis) and every
// device's measured control latency, in SQLite (WAL mode, cached prepared statements
// through sqlite_statement.h, schema version in PRAGMA user_version).
//
// States: queued -> running -> succeeded | failed | cancelled | interrupted | device_lost;
// a queued job may also go straight to cancelled, interrupted or device_lost (its camera
// was unplugged: see service/jobs/camera_worker.h). Transitions are conditional UPDATEs
// (a job already finished is never overwritten), so a cancel racing a finish is safe.
// After a crash (kill -9), the next start first recovers the unfinished jobs' folders and
// sets their frame counts from them (service/jobs/job_recovery.h), then turns queued and
// running jobs into interrupted.
//
// Thread-safe: one connection behind a mutex; every statement is short (no capture work
// is done under it, and each is reset after use so no read stays open), so status
// requests never wait on a capture.
//
// Status reads are served from memory where they can (docs/service.md, "Threading
// model"): a running job's progress is kept in memory on every call and written to the
// database at most every kProgressRowFrames frames or kProgressRowMs (and always when it
// finishes or is interrupted), and get()/list() show the in-memory progress, so a reader is
// never behind the last progress() call; a finished job never changes, so the last
// finished records read (kFinishedCacheJobs, kFinishedCacheBytes) are kept and served
// without SQLite or JSON parsing.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "service/store/sqlite_statement.h"

namespace camlab::service {

// 1: the first schema. 2: jobs.state may be 'device_lost' (a version-1 database is
// migrated when opened).
inline constexpr int kSchemaVersion = 2;

// A running job's progress row is written after this many frames or this long (ms).
inline constexpr int kProgressRowFrames = 30;
inline constexpr int64_t kProgressRowMs = 1000;
// Finished job records kept in memory for status reads: at most this many, and at most
// this many bytes of stored request + result JSON in all (a calibration's report can be
// large; one larger than the whole budget is read from the database each time).
inline constexpr size_t kFinishedCacheJobs = 1024;
inline constexpr size_t kFinishedCacheBytes = 16 << 20;

enum class JobState {
  kQueued,
  kRunning,
  kSucceeded,
  kFailed,
  kCancelled,
  kInterrupted,
  kDeviceLost
};
const char* job_state_name(JobState state);
std::optional<JobState> parse_job_state(const std::string& name);
bool is_finished(JobState state);

struct JobRecord {
  int64_t id = 0;
  std::string kind;       // "capture", "latency_probe", "calibration", "analysis"
  std::string camera_id;  // capture and probe jobs; empty otherwise
  JobState state = JobState::kQueued;
  nlohmann::json request = nlohmann::json::object();
  std::string folder;  // relative to the data folder; empty when the job writes none
  int64_t created_ms = 0, started_ms = 0, finished_ms = 0;  // Unix time, 0 = not yet
  int frames_done = 0, frames_total = 0, frames_discarded = 0;
  std::string error_code, error_message;
  nlohmann::json result;  // null until finished (the report, the capture summary)
};

// The job as the API shows it (times as ISO 8601 UTC, progress as a fraction).
nlohmann::json to_json(const JobRecord& job);

// What changed about one job, as the change observer sees it; a client that wants more
// reads the job.
struct JobChange {
  int64_t id = 0;
  JobState state = JobState::kQueued;
  int frames_done = 0, frames_total = 0, frames_discarded = 0;
};

struct LatencyRecord {
  std::string camera_id;
  int latency_frames = 0;
  std::string source;  // "probe", "spec" (the virtual camera's), "default"
  int64_t measured_ms = 0;
  nlohmann::json details;  // the probe's trace and agreement
};

class JobStore {
 public:
  // Opens (creating) the database at `path`, in WAL mode; refuses a newer schema.
  static Result<std::unique_ptr<JobStore>> open(const std::filesystem::path& path);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  // Inserts a queued job; `folder_prefix` (e.g. "captures/job-") + the zero-padded id
  // becomes its folder when non-empty. Returns the stored record.
  Result<JobRecord> create(const std::string& kind, const std::string& camera_id,
                           const nlohmann::json& request, const std::string& folder_prefix,
                           int frames_total);

  Result<std::optional<JobRecord>> get(int64_t id);
  // Newest first; `state` filters when set; at most `limit` from `offset`.
  Result<std::vector<JobRecord>> list(std::optional<JobState> state, int limit, int offset);
  Result<std::map<std::string, int64_t>> count_by_state();

  // queued -> running; false when the job is no longer queued (cancelled meanwhile).
  Result<bool> start(int64_t id);
  // Progress of a running job: at once in memory, in the database as said above.
  Status progress(int64_t id, int frames_done, int frames_total, int frames_discarded);
  // queued|running -> a final state; false when it had already finished.
  Result<bool> finish(int64_t id, JobState state, const std::optional<Error>& error,
                      const nlohmann::json& result);
  // queued -> cancelled; false when the job is not queued.
  Result<bool> cancel_queued(int64_t id);
  // Every queued or running job -> interrupted with `message`; returns how many.
  Result<int> interrupt_unfinished(const std::string& message);

  // Told of every job that reaches a final state through finish() or cancel_queued(), as
  // it happens: its kind and the state stored (the metrics count finished jobs here, so
  // they can never disagree with the states in the database). Set before any job runs;
  // called with the store's lock held, so it must be quick and must not call the store.
  using FinishObserver = std::function<void(const std::string& kind, JobState state)>;
  void set_finish_observer(FinishObserver observer) { finish_observer_ = std::move(observer); }

  // Told of every change a client may want to see at once (server-sent events,
  // docs/service.md): a job created (queued), started (running), a progress report (each
  // call, in memory), a final state through finish() or cancel_queued(). Set before any
  // job runs; called with the store's lock held, so it must be quick and must not call
  // the store (the event hub copies the change into its own queue).
  using ChangeObserver = std::function<void(const JobChange& change)>;
  void set_change_observer(ChangeObserver observer) { change_observer_ = std::move(observer); }

  Status put_latency(const LatencyRecord& record);
  Result<std::optional<LatencyRecord>> latency(const std::string& camera_id);

 private:
  explicit JobStore(sqlite::Connection db);
  // The statement for `sql`, prepared on first use and kept (keyed by its text).
  Result<sqlite::Statement*> statement(std::string_view sql);
  // The cached statement `sql` with `args` bound, run to its end (execute: returns the rows
  // changed) or read row by row (query, query_jobs). `what` names the step in errors
  // ("database: start job: ..."). Callers hold mutex_. Defined in job_store.cpp, the only
  // user.
  template <class... Args>
  Result<int> execute(const char* what, const char* sql, const Args&... args);
  template <class OnRow, class... Args>
  Status query(const char* what, const char* sql, OnRow&& on_row, const Args&... args);
  template <class... Args>
  Result<std::vector<JobRecord>> query_jobs(const char* sql, const Args&... args);

  // The kind of job `id`, after a change of its state (callers hold mutex_).
  void notify_finished(int64_t id, JobState state);
  // Tells the change observer (callers hold mutex_).
  void notify_change(const JobChange& change) const {
    if (change_observer_) change_observer_(change);
  }

  // A running job's progress as last reported, and what the database holds of it.
  struct LiveProgress {
    int frames_done = 0, frames_total = 0, frames_discarded = 0;
    int written_frames_done = -1;  // -1: no row written yet
    int64_t written_ms = 0;
    bool dirty = false;  // memory is ahead of the database
  };
  // Callers hold mutex_.
  Status write_progress(int64_t id, LiveProgress& live);
  Status flush_progress(int64_t id);
  void show_live(JobRecord& job) const;
  void remember_finished(const JobRecord& job);

  sqlite::Connection db_;
  std::mutex mutex_;
  FinishObserver finish_observer_;
  ChangeObserver change_observer_;
  std::map<int64_t, LiveProgress> live_;
  std::set<int64_t> started_here_;  // jobs start() moved to running and not finished since
  struct CachedJob {
    JobRecord job;
    size_t bytes = 0;  // its request and result as stored
  };
  std::map<int64_t, CachedJob> finished_;  // the newest ids within the bounds above
  size_t finished_bytes_ = 0;
  // Declared after db_, so finalized before the connection closes.
  std::map<std::string, sqlite::Statement, std::less<>> statements_;
};

int64_t unix_time_ms();

}  // namespace camlab::service
