#include "service/store/sqlite_job_store.h"

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

// A row of SELECT kJobColumns.
JobRecord job_from_row(const Statement& row) {
  JobRecord job;
  job.id = row.column_int64(0);
  job.kind = row.column_text(1);
  job.camera_id = row.column_text(2);
  job.state = parse_job_state(row.column_text(3)).value_or(JobState::kFailed);
  job.request = parse_stored_json(row.column_text(4));
  job.folder = row.column_text(5);
  job.created_ms = row.column_int64(6);
  job.started_ms = row.column_int64(7);
  job.finished_ms = row.column_int64(8);
  job.frames_done = row.column_int(9);
  job.frames_total = row.column_int(10);
  job.frames_discarded = row.column_int(11);
  job.error_code = row.column_text(12);
  job.error_message = row.column_text(13);
  job.result = parse_stored_json(row.column_text(14));
  return job;
}

Error in_database(const Error& error, const char* what) {
  return error.with_context(std::string("database: ") + what + ": ");
}

}  // namespace

// Declared in job_store.h: the default store is this one.
Result<std::unique_ptr<JobStore>> JobStore::open(const std::filesystem::path& path) {
  return SqliteJobStore::open(path);
}

Result<std::unique_ptr<JobStore>> SqliteJobStore::open(const std::filesystem::path& path) {
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
  return std::unique_ptr<JobStore>(new SqliteJobStore(std::move(db)));
}

// One camlabd: no host name, and nothing to retry (a local file is there or not).
SqliteJobStore::SqliteJobStore(sqlite::Connection db)
    : JobStore("", StoreRetry{}), db_(std::move(db)) {}

SqliteJobStore::~SqliteJobStore() = default;  // statements_ go first, then the connection

Result<Statement*> SqliteJobStore::statement(std::string_view sql) {
  auto it = statements_.find(sql);
  if (it == statements_.end()) {
    Statement prepared;
    CAMLAB_ASSIGN(prepared, Statement::prepare(db_, sql, Statement::Lifetime::kPersistent));
    it = statements_.emplace(std::string(sql), std::move(prepared)).first;
  }
  return &it->second;
}

template <class... Args>
Result<int> SqliteJobStore::execute(const char* what, const char* sql, const Args&... args) {
  Result<Statement*> stmt = statement(sql);
  if (!stmt) return in_database(stmt.error(), what);
  Result<int> changed = (*stmt)->execute(args...);
  if (!changed) return in_database(changed.error(), what);
  return changed;
}

template <class OnRow, class... Args>
Status SqliteJobStore::query(const char* what, const char* sql, OnRow&& on_row,
                             const Args&... args) {
  Result<Statement*> stmt = statement(sql);
  if (!stmt) return in_database(stmt.error(), what);
  if (Status read = (*stmt)->query(std::forward<OnRow>(on_row), args...); !read)
    return in_database(read.error(), what);
  return {};
}

template <class... Args>
Result<std::vector<JobRecord>> SqliteJobStore::query_jobs(const char* sql, const Args&... args) {
  std::vector<JobRecord> jobs;
  if (Status read = query(
          "read jobs", sql, [&](const Statement& row) { jobs.push_back(job_from_row(row)); },
          args...);
      !read)
    return read.error();
  return jobs;
}

Result<JobRecord> SqliteJobStore::db_insert_job(const NewJob& job, const std::string&) {
  static const char* kInsert =
      "INSERT INTO jobs (kind, camera_id, state, request, created_ms, frames_total) "
      "VALUES (?, ?, 'queued', ?, ?, ?)";
  static const char* kSetFolder = "UPDATE jobs SET folder = ? WHERE id = ?";
  JobRecord record;
  record.kind = job.kind;
  record.camera_id = job.camera_id;
  record.created_ms = job.created_ms;
  record.frames_total = job.frames_total;
  if (auto inserted = execute("insert job", kInsert, job.kind, job.camera_id, job.request_text,
                              job.created_ms, job.frames_total);
      !inserted)
    return inserted.error();
  record.id = db_.last_insert_rowid();
  record.folder = job_folder_name(job.folder_prefix, record.id);
  if (!record.folder.empty())
    if (auto updated = execute("set job folder", kSetFolder, record.folder, record.id); !updated)
      return updated.error();
  return record;
}

Result<std::optional<JobRecord>> SqliteJobStore::db_get_job(int64_t id) {
  static const std::string sql = std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?";
  std::vector<JobRecord> jobs;
  CAMLAB_ASSIGN(jobs, query_jobs(sql.c_str(), id));
  if (jobs.empty()) return std::optional<JobRecord>();
  return std::optional<JobRecord>(std::move(jobs.front()));
}

Result<std::vector<JobRecord>> SqliteJobStore::db_list_jobs(std::optional<JobState> state,
                                                            int limit, int offset) {
  static const std::string all =
      std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT ? OFFSET ?";
  static const std::string by_state =
      std::string("SELECT ") + kJobColumns +
      " FROM jobs WHERE state = ? ORDER BY id DESC LIMIT ? OFFSET ?";
  if (state) return query_jobs(by_state.c_str(), job_state_name(*state), limit, offset);
  return query_jobs(all.c_str(), limit, offset);
}

Result<std::map<std::string, int64_t>> SqliteJobStore::db_count_by_state() {
  std::map<std::string, int64_t> counts;
  if (Status read =
          query("count jobs", "SELECT state, COUNT(*) FROM jobs GROUP BY state",
                [&](const Statement& row) { counts[row.column_text(0)] = row.column_int64(1); });
      !read)
    return read.error();
  return counts;
}

Result<bool> SqliteJobStore::db_start_job(int64_t id, int64_t now_ms, const std::string&) {
  int changed;
  CAMLAB_ASSIGN(changed, execute("start job",
                                 "UPDATE jobs SET state = 'running', started_ms = ? "
                                 "WHERE id = ? AND state = 'queued'",
                                 now_ms, id));
  return changed == 1;
}

Result<bool> SqliteJobStore::db_write_progress(int64_t id, int frames_done, int frames_total,
                                               int frames_discarded) {
  int changed;
  CAMLAB_ASSIGN(changed, execute("update progress",
                                 "UPDATE jobs SET frames_done = ?, frames_total = ?, "
                                 "frames_discarded = ? WHERE id = ? AND state = 'running'",
                                 frames_done, frames_total, frames_discarded, id));
  return changed == 1;
}

Result<bool> SqliteJobStore::db_finish_job(int64_t id, JobState state, int64_t now_ms,
                                           const std::string& error_code,
                                           const std::string& error_message,
                                           const std::optional<std::string>& result_text,
                                           const std::string&) {
  int changed;
  CAMLAB_ASSIGN(changed,
                execute("finish job",
                        "UPDATE jobs SET state = ?, finished_ms = ?, error_code = ?, "
                        "error_message = ?, result = ? "
                        "WHERE id = ? AND state IN ('queued', 'running')",
                        job_state_name(state), now_ms, error_code, error_message, result_text, id));
  return changed == 1;
}

Result<bool> SqliteJobStore::db_cancel_queued(int64_t id, int64_t now_ms, const std::string&) {
  int changed;
  CAMLAB_ASSIGN(changed, execute("cancel job",
                                 "UPDATE jobs SET state = 'cancelled', finished_ms = ?, "
                                 "error_code = 'cancelled', error_message = "
                                 "'cancelled before it started' WHERE id = ? AND state = 'queued'",
                                 now_ms, id));
  return changed == 1;
}

Result<JobStore::FinishedSummary> SqliteJobStore::db_finished_summary(int64_t id) {
  FinishedSummary summary;
  if (Status read = query(
          "read finished job",
          "SELECT kind, frames_done, frames_total, frames_discarded FROM jobs WHERE id = ?",
          [&](const Statement& row) {
            summary.kind = row.column_text(0);
            summary.frames_done = row.column_int(1);
            summary.frames_total = row.column_int(2);
            summary.frames_discarded = row.column_int(3);
          },
          id);
      !read)
    return read.error();
  return summary;
}

Result<int> SqliteJobStore::db_interrupt_unfinished(const std::string& message, int64_t now_ms) {
  return execute("interrupt jobs",
                 "UPDATE jobs SET state = 'interrupted', finished_ms = ?, "
                 "error_code = 'interrupted', error_message = ? "
                 "WHERE state IN ('queued', 'running')",
                 now_ms, message);
}

Status SqliteJobStore::db_put_latency(const LatencyRecord& record) {
  if (auto stored = execute(
          "store latency",
          "INSERT INTO devices (camera_id, latency_frames, latency_source, measured_ms, details) "
          "VALUES (?, ?, ?, ?, ?) "
          "ON CONFLICT (camera_id) DO UPDATE SET latency_frames = excluded.latency_frames, "
          "latency_source = excluded.latency_source, measured_ms = excluded.measured_ms, "
          "details = excluded.details",
          record.camera_id, record.latency_frames, record.source, record.measured_ms,
          dump_json(record.details));
      !stored)
    return stored.error();
  return {};
}

Result<std::optional<LatencyRecord>> SqliteJobStore::db_latency(const std::string& camera_id) {
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
            r.details = parse_stored_json(row.column_text(3));
          },
          camera_id);
      !read)
    return read.error();
  return found;
}

}  // namespace camlab::service
