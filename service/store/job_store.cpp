#include "service/store/job_store.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <utility>

namespace camlab::service {

namespace {

using sqlite::Statement;

const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS jobs (
  id               INTEGER PRIMARY KEY AUTOINCREMENT,
  kind             TEXT NOT NULL,
  camera_id        TEXT NOT NULL DEFAULT '',
  state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed',
                                                  'cancelled', 'interrupted', 'device_lost')),
  request          TEXT NOT NULL,
  folder           TEXT NOT NULL DEFAULT '',
  created_ms       INTEGER NOT NULL,
  started_ms       INTEGER NOT NULL DEFAULT 0,
  finished_ms      INTEGER NOT NULL DEFAULT 0,
  frames_done      INTEGER NOT NULL DEFAULT 0,
  frames_total     INTEGER NOT NULL DEFAULT 0,
  frames_discarded INTEGER NOT NULL DEFAULT 0,
  error_code       TEXT NOT NULL DEFAULT '',
  error_message    TEXT NOT NULL DEFAULT '',
  result           TEXT
);
CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs (state);
CREATE TABLE IF NOT EXISTS devices (
  camera_id      TEXT PRIMARY KEY,
  latency_frames INTEGER NOT NULL,
  latency_source TEXT NOT NULL,
  measured_ms    INTEGER NOT NULL,
  details        TEXT NOT NULL
);
)sql";

// Version 1 -> 2: SQLite cannot change a CHECK constraint in place, so the jobs table is
// copied into one made by kSchema (which runs next, in the same transaction). The index
// goes with the old table and kSchema makes it again.
const char* kMigrateFrom1 = R"sql(
ALTER TABLE jobs RENAME TO jobs_v1;
DROP INDEX IF EXISTS jobs_by_state;
)sql";
const char* kMigrateFrom1Copy = R"sql(
INSERT INTO jobs SELECT * FROM jobs_v1;
DROP TABLE jobs_v1;
)sql";

const char* kJobColumns =
    "id, kind, camera_id, state, request, folder, created_ms, started_ms, finished_ms, "
    "frames_done, frames_total, frames_discarded, error_code, error_message, result";

nlohmann::json parse_or_null(const std::string& text) {
  if (text.empty()) return nullptr;
  nlohmann::json json = nlohmann::json::parse(text, nullptr, false);
  return json.is_discarded() ? nlohmann::json(nullptr) : json;
}

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

std::string dump(const nlohmann::json& json) {
  return json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// A row of SELECT kJobColumns.
JobRecord job_from_row(const Statement& row) {
  JobRecord job;
  job.id = row.column_int64(0);
  job.kind = row.column_text(1);
  job.camera_id = row.column_text(2);
  job.state = parse_job_state(row.column_text(3)).value_or(JobState::kFailed);
  job.request = parse_or_null(row.column_text(4));
  job.folder = row.column_text(5);
  job.created_ms = row.column_int64(6);
  job.started_ms = row.column_int64(7);
  job.finished_ms = row.column_int64(8);
  job.frames_done = row.column_int(9);
  job.frames_total = row.column_int(10);
  job.frames_discarded = row.column_int(11);
  job.error_code = row.column_text(12);
  job.error_message = row.column_text(13);
  job.result = parse_or_null(row.column_text(14));
  return job;
}

Error in_database(const Error& error, const char* what) {
  return error.with_context(std::string("database: ") + what + ": ");
}

}  // namespace

int64_t unix_time_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
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

Result<std::unique_ptr<JobStore>> JobStore::open(const std::filesystem::path& path) {
  sqlite::Connection db;
  CAMLAB_ASSIGN(db, sqlite::Connection::open(path));
  db.set_busy_timeout(5000);
  // WAL: readers never block the writer and a crash leaves the database consistent;
  // synchronous=NORMAL is durable across a process crash (kill -9), which is the case
  // that matters here.
  for (const char* pragma : {"PRAGMA journal_mode=WAL", "PRAGMA synchronous=NORMAL"})
    if (auto s = db.execute_script(pragma); !s) return in_database(s.error(), pragma);
  int version = 0;
  {
    Statement read_version;
    CAMLAB_ASSIGN(read_version, Statement::prepare(db, "PRAGMA user_version"));
    sqlite::Step step;
    CAMLAB_ASSIGN(step, read_version.step());
    if (step == sqlite::Step::kRow) version = read_version.column_int(0);
  }
  if (version > kSchemaVersion)
    return make_error("unsupported", "the database " + path.string() + " has schema version " +
                                         std::to_string(version) + ", newer than this camlabd's " +
                                         std::to_string(kSchemaVersion));
  // The schema and its version in one transaction; a failure before COMMIT rolls back
  // (explicitly, or when the connection closes).
  if (auto s = db.execute_script("BEGIN IMMEDIATE"); !s) return in_database(s.error(), "begin");
  const bool migrate = version == 1;
  if (migrate)
    if (auto s = db.execute_script(kMigrateFrom1); !s) {
      (void)db.execute_script("ROLLBACK");
      return in_database(s.error(), "migrate the schema from version 1");
    }
  if (auto s = db.execute_script(kSchema); !s) {
    (void)db.execute_script("ROLLBACK");
    return in_database(s.error(), "create the schema");
  }
  if (migrate)
    if (auto s = db.execute_script(kMigrateFrom1Copy); !s) {
      (void)db.execute_script("ROLLBACK");
      return in_database(s.error(), "copy the jobs of schema version 1");
    }
  if (auto s = db.execute_script("PRAGMA user_version=" + std::to_string(kSchemaVersion)); !s)
    return in_database(s.error(), "set the schema version");
  if (auto s = db.execute_script("COMMIT"); !s) return in_database(s.error(), "commit");
  return std::unique_ptr<JobStore>(new JobStore(std::move(db)));
}

JobStore::JobStore(sqlite::Connection db) : db_(std::move(db)) {}

JobStore::~JobStore() = default;  // statements_ go first, then the connection

Result<Statement*> JobStore::statement(std::string_view sql) {
  auto it = statements_.find(sql);
  if (it == statements_.end()) {
    Statement prepared;
    CAMLAB_ASSIGN(prepared, Statement::prepare(db_, sql, Statement::Lifetime::kPersistent));
    it = statements_.emplace(std::string(sql), std::move(prepared)).first;
  }
  return &it->second;
}

template <class... Args>
Result<int> JobStore::execute(const char* what, const char* sql, const Args&... args) {
  Result<Statement*> stmt = statement(sql);
  if (!stmt) return in_database(stmt.error(), what);
  Result<int> changed = (*stmt)->execute(args...);
  if (!changed) return in_database(changed.error(), what);
  return changed;
}

template <class OnRow, class... Args>
Status JobStore::query(const char* what, const char* sql, OnRow&& on_row, const Args&... args) {
  Result<Statement*> stmt = statement(sql);
  if (!stmt) return in_database(stmt.error(), what);
  if (Status read = (*stmt)->query(std::forward<OnRow>(on_row), args...); !read)
    return in_database(read.error(), what);
  return {};
}

template <class... Args>
Result<std::vector<JobRecord>> JobStore::query_jobs(const char* sql, const Args&... args) {
  std::vector<JobRecord> jobs;
  if (Status read = query(
          "read jobs", sql, [&](const Statement& row) { jobs.push_back(job_from_row(row)); },
          args...);
      !read)
    return read.error();
  return jobs;
}

Result<JobRecord> JobStore::create(const std::string& kind, const std::string& camera_id,
                                   const nlohmann::json& request, const std::string& folder_prefix,
                                   int frames_total) {
  std::lock_guard lock(mutex_);
  static const char* kInsert =
      "INSERT INTO jobs (kind, camera_id, state, request, created_ms, frames_total) "
      "VALUES (?, ?, 'queued', ?, ?, ?)";
  static const char* kSetFolder = "UPDATE jobs SET folder = ? WHERE id = ?";
  JobRecord job;
  job.kind = kind;
  job.camera_id = camera_id;
  job.request = request;
  job.created_ms = unix_time_ms();
  job.frames_total = frames_total;
  if (auto inserted = execute("insert job", kInsert, kind, camera_id, dump(request), job.created_ms,
                              frames_total);
      !inserted)
    return inserted.error();
  job.id = db_.last_insert_rowid();
  if (!folder_prefix.empty()) {
    char number[32];
    std::snprintf(number, sizeof number, "%06lld", static_cast<long long>(job.id));
    job.folder = folder_prefix + number;
    if (auto updated = execute("set job folder", kSetFolder, job.folder, job.id); !updated)
      return updated.error();
  }
  notify_change({job.id, JobState::kQueued, 0, frames_total, 0});
  return job;
}

Result<std::optional<JobRecord>> JobStore::get(int64_t id) {
  std::lock_guard lock(mutex_);
  if (auto cached = finished_.find(id); cached != finished_.end())
    return std::optional<JobRecord>(cached->second.job);
  static const std::string sql = std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?";
  std::vector<JobRecord> jobs;
  CAMLAB_ASSIGN(jobs, query_jobs(sql.c_str(), id));
  if (jobs.empty()) return std::optional<JobRecord>();
  JobRecord& job = jobs.front();
  if (is_finished(job.state)) remember_finished(job);
  show_live(job);
  return std::optional<JobRecord>(std::move(job));
}

Result<std::vector<JobRecord>> JobStore::list(std::optional<JobState> state, int limit,
                                              int offset) {
  std::lock_guard lock(mutex_);
  static const std::string all =
      std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT ? OFFSET ?";
  static const std::string by_state =
      std::string("SELECT ") + kJobColumns +
      " FROM jobs WHERE state = ? ORDER BY id DESC LIMIT ? OFFSET ?";
  std::vector<JobRecord> jobs;
  if (state) {
    CAMLAB_ASSIGN(jobs, query_jobs(by_state.c_str(), job_state_name(*state), limit, offset));
  } else {
    CAMLAB_ASSIGN(jobs, query_jobs(all.c_str(), limit, offset));
  }
  for (JobRecord& job : jobs) show_live(job);
  return jobs;
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
  const size_t bytes = dump(job.request).size() + dump(job.result).size();
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

Result<std::map<std::string, int64_t>> JobStore::count_by_state() {
  std::lock_guard lock(mutex_);
  std::map<std::string, int64_t> counts;
  if (Status read =
          query("count jobs", "SELECT state, COUNT(*) FROM jobs GROUP BY state",
                [&](const Statement& row) { counts[row.column_text(0)] = row.column_int64(1); });
      !read)
    return read.error();
  return counts;
}

Result<bool> JobStore::start(int64_t id) {
  std::lock_guard lock(mutex_);
  int changed;
  CAMLAB_ASSIGN(changed, execute("start job",
                                 "UPDATE jobs SET state = 'running', started_ms = ? "
                                 "WHERE id = ? AND state = 'queued'",
                                 unix_time_ms(), id));
  if (changed == 1) {
    started_here_.insert(id);
    notify_change({id, JobState::kRunning});
  }
  return changed == 1;
}

Status JobStore::write_progress(int64_t id, LiveProgress& live) {
  int changed;
  CAMLAB_ASSIGN(changed, execute("update progress",
                                 "UPDATE jobs SET frames_done = ?, frames_total = ?, "
                                 "frames_discarded = ? WHERE id = ? AND state = 'running'",
                                 live.frames_done, live.frames_total, live.frames_discarded, id));
  live.written_frames_done = live.frames_done;
  live.written_ms = unix_time_ms();
  live.dirty = false;
  // Not running (finished meanwhile, or never started): nothing live to show.
  if (changed == 0) live_.erase(id);
  return {};
}

Status JobStore::flush_progress(int64_t id) {
  auto live = live_.find(id);
  if (live == live_.end()) return {};
  Status status = live->second.dirty ? write_progress(id, live->second) : Status{};
  live_.erase(id);
  return status;
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
  // kProgressRowMs go to the database; the rest only to memory (one SQLite write a frame
  // was the store mutex's largest holder during a capture).
  const bool due = live.written_frames_done < 0 || frames_done >= frames_total ||
                   frames_done - live.written_frames_done >= kProgressRowFrames ||
                   unix_time_ms() - live.written_ms >= kProgressRowMs;
  if (!due) return {};
  return write_progress(id, live);
}

Result<bool> JobStore::finish(int64_t id, JobState state, const std::optional<Error>& error,
                              const nlohmann::json& result) {
  std::lock_guard lock(mutex_);
  const std::string error_code = error ? std::string(name_of(error->code)) : "";
  const std::string error_message = error ? error->message : "";
  // A job without a result stores NULL, which reads back as null.
  const std::optional<std::string> result_text =
      result.is_null() ? std::nullopt : std::optional<std::string>(dump(result));
  // The last progress first, so the finished row holds it.
  if (Status flushed = flush_progress(id); !flushed) return flushed.error();
  int changed;
  CAMLAB_ASSIGN(changed, execute("finish job",
                                 "UPDATE jobs SET state = ?, finished_ms = ?, error_code = ?, "
                                 "error_message = ?, result = ? "
                                 "WHERE id = ? AND state IN ('queued', 'running')",
                                 job_state_name(state), unix_time_ms(), error_code, error_message,
                                 result_text, id));
  started_here_.erase(id);
  if (changed == 1) notify_finished(id, state);
  return changed == 1;
}

void JobStore::notify_finished(int64_t id, JobState state) {
  if (change_observer_) {
    JobChange change{id, state};
    (void)query(
        "read job progress",
        "SELECT frames_done, frames_total, frames_discarded FROM jobs WHERE id = ?",
        [&](const Statement& row) {
          change.frames_done = static_cast<int>(row.column_int64(0));
          change.frames_total = static_cast<int>(row.column_int64(1));
          change.frames_discarded = static_cast<int>(row.column_int64(2));
        },
        id);
    notify_change(change);
  }
  if (!finish_observer_) return;
  std::string kind;
  (void)query(
      "read job kind", "SELECT kind FROM jobs WHERE id = ?",
      [&](const Statement& row) { kind = row.column_text(0); }, id);
  finish_observer_(kind, state);
}

Result<bool> JobStore::cancel_queued(int64_t id) {
  std::lock_guard lock(mutex_);
  int changed;
  CAMLAB_ASSIGN(changed, execute("cancel job",
                                 "UPDATE jobs SET state = 'cancelled', finished_ms = ?, "
                                 "error_code = 'cancelled', error_message = "
                                 "'cancelled before it started' WHERE id = ? AND state = 'queued'",
                                 unix_time_ms(), id));
  if (changed == 1) notify_finished(id, JobState::kCancelled);
  return changed == 1;
}

Result<int> JobStore::interrupt_unfinished(const std::string& message) {
  std::lock_guard lock(mutex_);
  while (!live_.empty())
    if (Status flushed = flush_progress(live_.begin()->first); !flushed) return flushed.error();
  started_here_.clear();
  return execute("interrupt jobs",
                 "UPDATE jobs SET state = 'interrupted', finished_ms = ?, "
                 "error_code = 'interrupted', error_message = ? "
                 "WHERE state IN ('queued', 'running')",
                 unix_time_ms(), message);
}

Status JobStore::put_latency(const LatencyRecord& record) {
  std::lock_guard lock(mutex_);
  if (auto stored = execute(
          "store latency",
          "INSERT INTO devices (camera_id, latency_frames, latency_source, measured_ms, details) "
          "VALUES (?, ?, ?, ?, ?) "
          "ON CONFLICT (camera_id) DO UPDATE SET latency_frames = excluded.latency_frames, "
          "latency_source = excluded.latency_source, measured_ms = excluded.measured_ms, "
          "details = excluded.details",
          record.camera_id, record.latency_frames, record.source, record.measured_ms,
          dump(record.details));
      !stored)
    return stored.error();
  return {};
}

Result<std::optional<LatencyRecord>> JobStore::latency(const std::string& camera_id) {
  std::lock_guard lock(mutex_);
  std::optional<LatencyRecord> found;
  if (Status read = query(
          "read latency",
          "SELECT latency_frames, latency_source, measured_ms, details FROM devices "
          "WHERE camera_id = ?",
          [&](const Statement& row) {
            LatencyRecord& r = found.emplace();
            r.camera_id = camera_id;
            r.latency_frames = row.column_int(0);
            r.source = row.column_text(1);
            r.measured_ms = row.column_int64(2);
            r.details = parse_or_null(row.column_text(3));
          },
          camera_id);
      !read)
    return read.error();
  return found;
}

}  // namespace camlab::service
