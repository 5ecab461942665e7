// The job store: every job (capture, latency probe, calibration, analysis, synchronised
// capture) and every camera's measured control latency. Two databases stand behind this
// one interface: SQLite, one camlabd's own file (the default; sqlite_job_store.h), and
// PostgreSQL, shared by a fleet of camlabd hosts (`--db postgresql://...`;
// postgres_job_store.h, with the fleet's own operations in fleet_store.h).
//
// States: queued -> running -> succeeded | failed | cancelled | interrupted | device_lost;
// a queued job may also go straight to cancelled, interrupted or device_lost (its camera
// was unplugged: see service/jobs/camera_worker.h). Transitions are conditional UPDATEs
// (a job already finished is never overwritten), so a cancel racing a finish is safe.
// After a crash (kill -9), the next start first recovers the unfinished jobs' folders and
// sets their frame counts from them (service/jobs/job_recovery.h), then turns queued and
// running jobs into interrupted (on PostgreSQL: this host's).
//
// This class is the part both databases share, so that they behave the same: the public
// operations, the in-memory progress and finished-job cache, the observers, and the retry
// of a write while the database is unreachable. Each database supplies the statements (the
// protected `db_` members), which this class calls with its mutex held.
//
// Thread-safe: one mutex around every operation; every statement is short (no capture
// work is done under it), so status requests never wait on a capture.
//
// Status reads are served from memory where they can (docs/service.md, "Threading
// model"): a running job's progress is kept in memory on every call and written to the
// database at most every kProgressRowFrames frames or kProgressRowMs (and always when it
// finishes or is interrupted), and get()/list() show the in-memory progress, so a reader is
// never behind the last progress() call; a finished job never changes, so the last
// finished records read (kFinishedCacheJobs, kFinishedCacheBytes) are kept and served
// without the database or JSON parsing.
//
// A database that cannot be reached (PostgreSQL restarting, the network cut) is the error
// "database_unavailable". The writes a camera's worker makes to run a job (start, finish,
// latency) are tried again with a bounded backoff for StoreRetry::worker_patience, so that
// a restart of the database loses no record; the writes an HTTP request makes (create,
// cancel) for the shorter request_patience; reads and progress reports are not retried
// (progress stays in memory and is written with the next report or the finish).
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"

namespace camlab::service {

class FleetStore;

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
  std::string kind;       // "capture", "latency_probe", "calibration", "analysis", ...
  std::string camera_id;  // capture and probe jobs; empty otherwise
  // The fleet host that runs the job and keeps its files (its camera's host); empty on a
  // single camlabd (SQLite).
  std::string host;
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

// `prefix` + the id zero-padded to 6 digits ("captures/job-000042"); empty without prefix.
std::string job_folder_name(const std::string& prefix, int64_t id);

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
  std::string source;       // "probe", "spec" (the virtual camera's), "default"
  int64_t measured_ms = 0;  // when it was measured: Unix time in ms (the API's measured_at_unix_ms)
  nlohmann::json details;   // the probe's trace and agreement
};

// How long a write is tried again while the database is unavailable (see above).
struct StoreRetry {
  std::chrono::milliseconds worker_patience{30000};
  std::chrono::milliseconds request_patience{2000};
};

class JobStore {
 public:
  // The SQLite store of one camlabd (sqlite_job_store.h): opens (creating) the database at
  // `path`, in WAL mode; refuses a newer schema.
  static Result<std::unique_ptr<JobStore>> open(const std::filesystem::path& path);
  virtual ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  // Inserts a queued job that this camlabd runs; `folder_prefix` (e.g. "captures/job-") +
  // the zero-padded id becomes its folder when non-empty. Returns the stored record.
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
  // Every queued or running job (on PostgreSQL: every one this host had taken) ->
  // interrupted with `message`; returns how many.
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
  // Hands the change observer a change another fleet host made (service/fleet/ reads them
  // from the database's notifications), so that a host's live job list shows the fleet's,
  // and drops this store's cached copy of the job if it has one.
  void relay_change(const JobChange& change);

  Status put_latency(const LatencyRecord& record);
  Result<std::optional<LatencyRecord>> latency(const std::string& camera_id);

  // The fleet's operations when several hosts share this store (PostgreSQL), else null.
  virtual FleetStore* fleet() { return nullptr; }
  // The host this store's own jobs run on; empty for a single camlabd.
  const std::string& local_host() const { return local_host_; }

 protected:
  JobStore(std::string local_host, StoreRetry retry);

  // What the database is asked to insert for create().
  struct NewJob {
    std::string kind, camera_id, request_text, folder_prefix;
    int frames_total = 0;
    int64_t created_ms = 0;
  };
  // The kind and stored progress of a job, told to the observers when it finishes.
  struct FinishedSummary {
    std::string kind;
    int frames_done = 0, frames_total = 0, frames_discarded = 0;
  };

  // The database's part, each called with mutex_ held. `op` names one logical operation
  // (the same string when a write is tried again), so that a write whose commit was in
  // doubt when the connection broke is not applied twice; a database without that doubt
  // ignores it. Changes return whether the row changed (the transition was allowed).
  virtual Result<JobRecord> db_insert_job(const NewJob& job, const std::string& op) = 0;
  virtual Result<std::optional<JobRecord>> db_get_job(int64_t id) = 0;
  virtual Result<std::vector<JobRecord>> db_list_jobs(std::optional<JobState> state, int limit,
                                                      int offset) = 0;
  virtual Result<std::map<std::string, int64_t>> db_count_by_state() = 0;
  virtual Result<bool> db_start_job(int64_t id, int64_t now_ms, const std::string& op) = 0;
  // False when the job is not running (finished meanwhile, or never started).
  virtual Result<bool> db_write_progress(int64_t id, int frames_done, int frames_total,
                                         int frames_discarded) = 0;
  virtual Result<bool> db_finish_job(int64_t id, JobState state, int64_t now_ms,
                                     const std::string& error_code,
                                     const std::string& error_message,
                                     const std::optional<std::string>& result_text,
                                     const std::string& op) = 0;
  virtual Result<bool> db_cancel_queued(int64_t id, int64_t now_ms, const std::string& op) = 0;
  virtual Result<FinishedSummary> db_finished_summary(int64_t id) = 0;
  virtual Result<int> db_interrupt_unfinished(const std::string& message, int64_t now_ms) = 0;
  virtual Status db_put_latency(const LatencyRecord& record) = 0;
  virtual Result<std::optional<LatencyRecord>> db_latency(const std::string& camera_id) = 0;

  // Guards the database connection and everything below; derived classes' own
  // operations take it too.
  std::mutex mutex_;

 private:
  enum class Patience { kNone, kRequest, kWorker };
  // Runs `attempt` with mutex_ held, again while the database is unavailable and the
  // patience allows (store_retry.h).
  template <class Attempt>
  auto with_retry(Patience patience, Attempt&& attempt) -> decltype(attempt());
  // A new operation's name (takes mutex_).
  std::string next_op();

  // Tells the observers of a job that reached `state` (callers hold mutex_).
  void notify_finished(int64_t id, JobState state);
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

  const std::string local_host_;
  const StoreRetry retry_;
  const std::string op_prefix_;  // random per store: ops of two stores never collide
  uint64_t op_counter_ = 0;      // under mutex_
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
};

int64_t unix_time_ms();

// The JSON text a job's request or result is stored as (invalid UTF-8 replaced).
std::string dump_json(const nlohmann::json& json);
// Stored JSON text back into JSON; null for empty or malformed text.
nlohmann::json parse_stored_json(const std::string& text);

}  // namespace camlab::service
