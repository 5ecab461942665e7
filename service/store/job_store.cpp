#include "service/store/job_store.h"

#include <chrono>
#include <cstdio>
#include <ctime>

namespace camlab::service {

namespace {

const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS jobs (
  id               INTEGER PRIMARY KEY AUTOINCREMENT,
  kind             TEXT NOT NULL,
  camera_id        TEXT NOT NULL DEFAULT '',
  state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed',
                                                  'cancelled', 'interrupted')),
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

const char* kJobColumns =
    "id, kind, camera_id, state, request, folder, created_ms, started_ms, finished_ms, frames_done, "
    "frames_total, frames_discarded, error_code, error_message, result";

// Resets a statement when leaving scope, so no read snapshot stays open between calls.
struct ResetOnExit {
  sqlite3_stmt* stmt;
  ~ResetOnExit() { sqlite3_reset(stmt); }
};

std::string column_text(sqlite3_stmt* stmt, int column) {
  const unsigned char* text = sqlite3_column_text(stmt, column);
  return text ? reinterpret_cast<const char*>(text) : "";
}

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
  std::snprintf(buffer, sizeof buffer, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms % 1000));
  return buffer;
}

std::string dump(const nlohmann::json& json) {
  return json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

int64_t unix_time_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const char* job_state_name(JobState state) {
  switch (state) {
    case JobState::kQueued: return "queued";
    case JobState::kRunning: return "running";
    case JobState::kSucceeded: return "succeeded";
    case JobState::kFailed: return "failed";
    case JobState::kCancelled: return "cancelled";
    case JobState::kInterrupted: return "interrupted";
  }
  return "failed";
}

std::optional<JobState> parse_job_state(const std::string& name) {
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kSucceeded, JobState::kFailed,
                     JobState::kCancelled, JobState::kInterrupted})
    if (name == job_state_name(s)) return s;
  return std::nullopt;
}

bool is_finished(JobState state) { return state != JobState::kQueued && state != JobState::kRunning; }

nlohmann::json to_json(const JobRecord& job) {
  nlohmann::json json = {{"id", job.id},
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
  json["started_at"] = job.started_ms ? nlohmann::json(iso_time(job.started_ms)) : nlohmann::json(nullptr);
  json["finished_at"] = job.finished_ms ? nlohmann::json(iso_time(job.finished_ms)) : nlohmann::json(nullptr);
  if (!job.error_code.empty()) json["error"] = {{"code", job.error_code}, {"message", job.error_message}};
  json["result"] = job.result;
  return json;
}

Result<std::unique_ptr<JobStore>> JobStore::open(const std::filesystem::path& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                                 nullptr);
  if (rc != SQLITE_OK) {
    std::string message = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    return make_error("io_error", "cannot open the database " + path.string() + ": " + message);
  }
  std::unique_ptr<JobStore> store(new JobStore(db));
  sqlite3_busy_timeout(db, 5000);
  // WAL: readers never block the writer and a crash leaves the database consistent;
  // synchronous=NORMAL is durable across a process crash (kill -9), which is the case
  // that matters here.
  for (const char* pragma : {"PRAGMA journal_mode=WAL", "PRAGMA synchronous=NORMAL"})
    if (auto s = store->exec(pragma); !s) return s.error();
  sqlite3_stmt* version_stmt = nullptr;
  int version = 0;
  if (sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &version_stmt, nullptr) == SQLITE_OK &&
      sqlite3_step(version_stmt) == SQLITE_ROW)
    version = sqlite3_column_int(version_stmt, 0);
  sqlite3_finalize(version_stmt);
  if (version > kSchemaVersion)
    return make_error("unsupported", "the database " + path.string() + " has schema version " +
                                         std::to_string(version) + ", newer than this camlabd's " +
                                         std::to_string(kSchemaVersion));
  if (auto s = store->exec("BEGIN IMMEDIATE"); !s) return s.error();
  if (auto s = store->exec(kSchema); !s) {
    (void)store->exec("ROLLBACK");
    return s.error();
  }
  if (auto s = store->exec(("PRAGMA user_version=" + std::to_string(kSchemaVersion)).c_str()); !s) return s.error();
  if (auto s = store->exec("COMMIT"); !s) return s.error();
  return store;
}

JobStore::~JobStore() {
  for (auto& [sql, stmt] : statements_) sqlite3_finalize(stmt);
  sqlite3_close(db_);
}

Error JobStore::db_error(const std::string& what) const {
  return make_error("io_error", "database: " + what + ": " + sqlite3_errmsg(db_));
}

Status JobStore::exec(const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    Error e = make_error("io_error", std::string("database: ") + (message ? message : "error"));
    sqlite3_free(message);
    return e;
  }
  return {};
}

Result<sqlite3_stmt*> JobStore::statement(const char* sql) {
  auto it = statements_.find(sql);
  if (it != statements_.end()) {
    sqlite3_reset(it->second);
    sqlite3_clear_bindings(it->second);
    return it->second;
  }
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v3(db_, sql, -1, SQLITE_PREPARE_PERSISTENT, &stmt, nullptr) != SQLITE_OK)
    return db_error("prepare");
  statements_[sql] = stmt;
  return stmt;
}

Result<std::vector<JobRecord>> JobStore::query_jobs(sqlite3_stmt* stmt) {
  std::vector<JobRecord> jobs;
  int rc;
  while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
    JobRecord j;
    j.id = sqlite3_column_int64(stmt, 0);
    j.kind = column_text(stmt, 1);
    j.camera_id = column_text(stmt, 2);
    j.state = parse_job_state(column_text(stmt, 3)).value_or(JobState::kFailed);
    j.request = parse_or_null(column_text(stmt, 4));
    j.folder = column_text(stmt, 5);
    j.created_ms = sqlite3_column_int64(stmt, 6);
    j.started_ms = sqlite3_column_int64(stmt, 7);
    j.finished_ms = sqlite3_column_int64(stmt, 8);
    j.frames_done = sqlite3_column_int(stmt, 9);
    j.frames_total = sqlite3_column_int(stmt, 10);
    j.frames_discarded = sqlite3_column_int(stmt, 11);
    j.error_code = column_text(stmt, 12);
    j.error_message = column_text(stmt, 13);
    j.result = parse_or_null(column_text(stmt, 14));
    jobs.push_back(std::move(j));
  }
  if (rc != SQLITE_DONE) return db_error("read jobs");
  return jobs;
}

Result<JobRecord> JobStore::create(const std::string& kind, const std::string& camera_id,
                                   const nlohmann::json& request, const std::string& folder_prefix,
                                   int frames_total) {
  std::lock_guard lock(mutex_);
  static const char* kInsert =
      "INSERT INTO jobs (kind, camera_id, state, request, created_ms, frames_total) VALUES (?, ?, 'queued', ?, ?, ?)";
  static const char* kSetFolder = "UPDATE jobs SET folder = ? WHERE id = ?";
  sqlite3_stmt* insert;
  CAMLAB_ASSIGN(insert, statement(kInsert));
  ResetOnExit reset_insert{insert};
  const std::string request_text = dump(request);
  JobRecord job;
  job.kind = kind;
  job.camera_id = camera_id;
  job.request = request;
  job.created_ms = unix_time_ms();
  job.frames_total = frames_total;
  sqlite3_bind_text(insert, 1, kind.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(insert, 2, camera_id.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(insert, 3, request_text.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(insert, 4, job.created_ms);
  sqlite3_bind_int(insert, 5, frames_total);
  if (sqlite3_step(insert) != SQLITE_DONE) return db_error("insert job");
  job.id = sqlite3_last_insert_rowid(db_);
  if (!folder_prefix.empty()) {
    char number[32];
    std::snprintf(number, sizeof number, "%06lld", static_cast<long long>(job.id));
    job.folder = folder_prefix + number;
    sqlite3_stmt* update;
    CAMLAB_ASSIGN(update, statement(kSetFolder));
    ResetOnExit reset_update{update};
    sqlite3_bind_text(update, 1, job.folder.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_int64(update, 2, job.id);
    if (sqlite3_step(update) != SQLITE_DONE) return db_error("set job folder");
  }
  return job;
}

Result<std::optional<JobRecord>> JobStore::get(int64_t id) {
  std::lock_guard lock(mutex_);
  static const std::string sql = std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql.c_str()));
  ResetOnExit reset_stmt{stmt};
  sqlite3_bind_int64(stmt, 1, id);
  std::vector<JobRecord> jobs;
  CAMLAB_ASSIGN(jobs, query_jobs(stmt));
  if (jobs.empty()) return std::optional<JobRecord>();
  return std::optional<JobRecord>(std::move(jobs.front()));
}

Result<std::vector<JobRecord>> JobStore::list(std::optional<JobState> state, int limit, int offset) {
  std::lock_guard lock(mutex_);
  static const std::string all =
      std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT ? OFFSET ?";
  static const std::string by_state =
      std::string("SELECT ") + kJobColumns + " FROM jobs WHERE state = ? ORDER BY id DESC LIMIT ? OFFSET ?";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(state ? by_state.c_str() : all.c_str()));
  ResetOnExit reset_stmt{stmt};
  int index = 1;
  if (state) sqlite3_bind_text(stmt, index++, job_state_name(*state), -1, SQLITE_STATIC);
  sqlite3_bind_int(stmt, index++, limit);
  sqlite3_bind_int(stmt, index++, offset);
  return query_jobs(stmt);
}

Result<std::map<std::string, int64_t>> JobStore::count_by_state() {
  std::lock_guard lock(mutex_);
  static const char* sql = "SELECT state, COUNT(*) FROM jobs GROUP BY state";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  std::map<std::string, int64_t> counts;
  int rc;
  while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) counts[column_text(stmt, 0)] = sqlite3_column_int64(stmt, 1);
  if (rc != SQLITE_DONE) return db_error("count jobs");
  return counts;
}

Result<bool> JobStore::start(int64_t id) {
  std::lock_guard lock(mutex_);
  static const char* sql = "UPDATE jobs SET state = 'running', started_ms = ? WHERE id = ? AND state = 'queued'";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  sqlite3_bind_int64(stmt, 1, unix_time_ms());
  sqlite3_bind_int64(stmt, 2, id);
  if (sqlite3_step(stmt) != SQLITE_DONE) return db_error("start job");
  return sqlite3_changes(db_) == 1;
}

Status JobStore::progress(int64_t id, int frames_done, int frames_total, int frames_discarded) {
  std::lock_guard lock(mutex_);
  static const char* sql =
      "UPDATE jobs SET frames_done = ?, frames_total = ?, frames_discarded = ? WHERE id = ? AND state = 'running'";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  sqlite3_bind_int(stmt, 1, frames_done);
  sqlite3_bind_int(stmt, 2, frames_total);
  sqlite3_bind_int(stmt, 3, frames_discarded);
  sqlite3_bind_int64(stmt, 4, id);
  if (sqlite3_step(stmt) != SQLITE_DONE) return db_error("update progress");
  return {};
}

Result<bool> JobStore::finish(int64_t id, JobState state, const std::optional<Error>& error,
                              const nlohmann::json& result) {
  std::lock_guard lock(mutex_);
  static const char* sql =
      "UPDATE jobs SET state = ?, finished_ms = ?, error_code = ?, error_message = ?, result = ? "
      "WHERE id = ? AND state IN ('queued', 'running')";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  const std::string result_text = result.is_null() ? "" : dump(result);
  sqlite3_bind_text(stmt, 1, job_state_name(state), -1, SQLITE_STATIC);
  sqlite3_bind_int64(stmt, 2, unix_time_ms());
  sqlite3_bind_text(stmt, 3, error ? std::string(name_of(error->code)).c_str() : "", -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(stmt, 4, error ? error->message.c_str() : "", -1, SQLITE_TRANSIENT);
  if (result_text.empty())
    sqlite3_bind_null(stmt, 5);
  else
    sqlite3_bind_text(stmt, 5, result_text.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(stmt, 6, id);
  if (sqlite3_step(stmt) != SQLITE_DONE) return db_error("finish job");
  return sqlite3_changes(db_) == 1;
}

Result<bool> JobStore::cancel_queued(int64_t id) {
  std::lock_guard lock(mutex_);
  static const char* sql =
      "UPDATE jobs SET state = 'cancelled', finished_ms = ?, error_code = 'cancelled', "
      "error_message = 'cancelled before it started' WHERE id = ? AND state = 'queued'";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  sqlite3_bind_int64(stmt, 1, unix_time_ms());
  sqlite3_bind_int64(stmt, 2, id);
  if (sqlite3_step(stmt) != SQLITE_DONE) return db_error("cancel job");
  return sqlite3_changes(db_) == 1;
}

Result<int> JobStore::interrupt_unfinished(const std::string& message) {
  std::lock_guard lock(mutex_);
  static const char* sql =
      "UPDATE jobs SET state = 'interrupted', finished_ms = ?, error_code = 'interrupted', error_message = ? "
      "WHERE state IN ('queued', 'running')";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  sqlite3_bind_int64(stmt, 1, unix_time_ms());
  sqlite3_bind_text(stmt, 2, message.c_str(), -1, SQLITE_TRANSIENT);
  if (sqlite3_step(stmt) != SQLITE_DONE) return db_error("interrupt jobs");
  return sqlite3_changes(db_);
}

Status JobStore::put_latency(const LatencyRecord& record) {
  std::lock_guard lock(mutex_);
  static const char* sql =
      "INSERT INTO devices (camera_id, latency_frames, latency_source, measured_ms, details) VALUES (?, ?, ?, ?, ?) "
      "ON CONFLICT (camera_id) DO UPDATE SET latency_frames = excluded.latency_frames, "
      "latency_source = excluded.latency_source, measured_ms = excluded.measured_ms, details = excluded.details";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  const std::string details = dump(record.details);
  sqlite3_bind_text(stmt, 1, record.camera_id.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int(stmt, 2, record.latency_frames);
  sqlite3_bind_text(stmt, 3, record.source.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(stmt, 4, record.measured_ms);
  sqlite3_bind_text(stmt, 5, details.c_str(), -1, SQLITE_TRANSIENT);
  if (sqlite3_step(stmt) != SQLITE_DONE) return db_error("store latency");
  return {};
}

Result<std::optional<LatencyRecord>> JobStore::latency(const std::string& camera_id) {
  std::lock_guard lock(mutex_);
  static const char* sql =
      "SELECT latency_frames, latency_source, measured_ms, details FROM devices WHERE camera_id = ?";
  sqlite3_stmt* stmt;
  CAMLAB_ASSIGN(stmt, statement(sql));
  ResetOnExit reset_stmt{stmt};
  sqlite3_bind_text(stmt, 1, camera_id.c_str(), -1, SQLITE_TRANSIENT);
  const int rc = sqlite3_step(stmt);
  if (rc == SQLITE_DONE) return std::optional<LatencyRecord>();
  if (rc != SQLITE_ROW) return db_error("read latency");
  LatencyRecord r;
  r.camera_id = camera_id;
  r.latency_frames = sqlite3_column_int(stmt, 0);
  r.source = column_text(stmt, 1);
  r.measured_ms = sqlite3_column_int64(stmt, 2);
  r.details = parse_or_null(column_text(stmt, 3));
  return std::optional<LatencyRecord>(std::move(r));
}

}  // namespace camlab::service
