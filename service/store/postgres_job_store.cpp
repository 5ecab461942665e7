#include "service/store/postgres_job_store.h"

#include <thread>
#include <utility>

#include "base/log.h"
#include "service/store/postgres_fleet.h"
#include "service/store/postgres_schema.h"

namespace camlab::service {

namespace {

using postgres::Connection;

const std::string kColumns = kPostgresJobColumns;

}  // namespace

void prepare_postgres_job_statements(pqxx::connection& conn) {
  // One round trip: the id is drawn first so that the folder can be named from it in the
  // same INSERT (job_folder_name's rule: 6 digits, zero-padded, more when needed). A retry
  // of an insert whose commit was in doubt finds the row by its create_op.
  conn.prepare("insert_job",
               "WITH next AS (SELECT nextval(pg_get_serial_sequence('jobs', 'id')) AS id) "
               "INSERT INTO jobs (id, kind, camera_id, host, claimed, state, request, folder, "
               "created_ms, frames_total, create_op, last_op) "
               "SELECT id, $1, $2, $3, $4, 'queued', $5, "
               "CASE WHEN $6::text = '' THEN '' ELSE $6::text || CASE WHEN id < 1000000 "
               "THEN lpad(id::text, 6, '0') ELSE id::text END END, $7, $8, $9, $9 FROM next "
               "WHERE NOT $10::boolean OR EXISTS (SELECT 1 FROM hosts WHERE name = $3 AND "
               "state = 'live' AND lease_until > clock_timestamp()) "
               "ON CONFLICT (create_op) DO UPDATE SET create_op = EXCLUDED.create_op "
               "RETURNING id, folder");
  conn.prepare("get_job", "SELECT " + kColumns + " FROM jobs WHERE id = $1");
  conn.prepare("list_jobs",
               "SELECT " + kColumns + " FROM jobs ORDER BY id DESC LIMIT $1 OFFSET $2");
  conn.prepare("list_jobs_in_state", "SELECT " + kColumns +
                                         " FROM jobs WHERE state = $1 ORDER BY id DESC "
                                         "LIMIT $2 OFFSET $3");
  conn.prepare("count_jobs", "SELECT state, count(*) FROM jobs GROUP BY state");
  conn.prepare("start_job",
               "UPDATE jobs SET state = 'running', started_ms = $2, last_op = $3 "
               "WHERE id = $1 AND host = $4 AND claimed "
               "AND (state = 'queued' OR (state = 'running' AND last_op = $3))");
  conn.prepare("job_progress",
               "UPDATE jobs SET frames_done = $2, frames_total = $3, frames_discarded = $4 "
               "WHERE id = $1 AND host = $5 AND state = 'running'");
  conn.prepare("finish_job",
               "UPDATE jobs SET state = $2, finished_ms = $3, error_code = $4, "
               "error_message = $5, result = $6, last_op = $7 "
               "WHERE id = $1 AND host = $8 AND (state IN ('queued', 'running') OR last_op = $7)");
  conn.prepare("cancel_queued",
               "UPDATE jobs SET state = 'cancelled', finished_ms = $2, error_code = 'cancelled', "
               "error_message = 'cancelled before it started', last_op = $3 "
               "WHERE id = $1 AND (state = 'queued' OR (state = 'cancelled' AND last_op = $3))");
  conn.prepare("finished_summary",
               "SELECT kind, frames_done, frames_total, frames_discarded FROM jobs WHERE id = $1");
  conn.prepare("interrupt_unfinished",
               "UPDATE jobs SET state = 'interrupted', finished_ms = $2, "
               "error_code = 'interrupted', error_message = $3 "
               "WHERE host = $1 AND claimed AND state IN ('queued', 'running')");
  conn.prepare("put_latency",
               "INSERT INTO devices (host, camera_id, latency_frames, latency_source, "
               "measured_ms, details) VALUES ($1, $2, $3, $4, $5, $6) "
               "ON CONFLICT (host, camera_id) DO UPDATE SET "
               "latency_frames = EXCLUDED.latency_frames, "
               "latency_source = EXCLUDED.latency_source, measured_ms = EXCLUDED.measured_ms, "
               "details = EXCLUDED.details");
  conn.prepare("get_latency",
               "SELECT latency_frames, latency_source, measured_ms, details FROM devices "
               "WHERE host = $1 AND camera_id = $2");
}

namespace {

std::vector<JobRecord> jobs_from(const pqxx::result& rows) {
  std::vector<JobRecord> jobs;
  jobs.reserve(rows.size());
  for (const pqxx::row& row : rows) jobs.push_back(job_from_postgres_row(row));
  return jobs;
}

// NULL for no result (libpqxx 6 binds a null const char* as NULL).
const char* text_or_null(const std::optional<std::string>& text) {
  return text ? text->c_str() : nullptr;
}

}  // namespace

JobRecord job_from_postgres_row(const pqxx::row& row) {
  JobRecord job;
  job.id = row[0].as<int64_t>();
  job.kind = row[1].c_str();
  job.camera_id = row[2].c_str();
  job.host = row[3].c_str();
  job.state = parse_job_state(row[4].c_str()).value_or(JobState::kFailed);
  job.request = parse_stored_json(row[5].c_str());
  job.folder = row[6].c_str();
  job.created_ms = row[7].as<int64_t>();
  job.started_ms = row[8].as<int64_t>();
  job.finished_ms = row[9].as<int64_t>();
  job.frames_done = row[10].as<int>();
  job.frames_total = row[11].as<int>();
  job.frames_discarded = row[12].as<int>();
  job.error_code = row[13].c_str();
  job.error_message = row[14].c_str();
  job.result = row[15].is_null() ? nlohmann::json(nullptr) : parse_stored_json(row[15].c_str());
  return job;
}

PostgresJobStore::PostgresJobStore(const PostgresStoreOptions& options)
    : JobStore(options.host, options.retry),
      options_(options),
      conn_(
          postgres::ConnectOptions{options.url, options.connect_timeout, options.statement_timeout},
          prepare_postgres_job_statements) {}

PostgresJobStore::~PostgresJobStore() = default;

Result<std::unique_ptr<PostgresJobStore>> PostgresJobStore::open(
    const PostgresStoreOptions& options) {
  if (options.host.empty())
    return make_error("invalid_argument", "a fleet host needs a name (--host-name)");
  std::unique_ptr<PostgresJobStore> store(new PostgresJobStore(options));
  // The database may come up with the hosts (one boot, one systemd target): wait for it,
  // within the workers' patience, saying so.
  const auto deadline = std::chrono::steady_clock::now() + options.retry.worker_patience;
  for (;;) {
    Status schema = postgres::create_schema(store->conn_);
    if (schema) break;
    if (schema.error().code != ErrorCode::kDatabaseUnavailable ||
        std::chrono::steady_clock::now() >= deadline)
      return schema.error();
    log_warning(log::Category::kDaemon, "%s; trying again", schema.error().message.c_str());
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  store->fleet_ = std::make_unique<PostgresFleet>(*store, options);
  return store;
}

FleetStore* PostgresJobStore::fleet() { return fleet_.get(); }

Status PostgresJobStore::check_not_fenced(const char* what) const {
  if (!fenced_) return {};
  return make_error("database_unavailable",
                    std::string("database: ") + what + ": host " + local_host() +
                        " could not renew its lease in time (cut off from the database) and "
                        "makes no job step until it has joined the fleet again");
}

Result<JobRecord> PostgresJobStore::db_insert_job(const NewJob& job, const std::string& op) {
  return conn_.transact("insert job", [&](pqxx::work& tx) {
    const pqxx::row row = tx.exec_prepared1("insert_job", job.kind, job.camera_id, local_host(),
                                            true, job.request_text, job.folder_prefix,
                                            job.created_ms, job.frames_total, op, false);
    JobRecord record;
    record.id = row[0].as<int64_t>();
    record.folder = row[1].c_str();
    record.kind = job.kind;
    record.camera_id = job.camera_id;
    record.host = local_host();
    record.created_ms = job.created_ms;
    record.frames_total = job.frames_total;
    return record;
  });
}

Result<std::optional<JobRecord>> PostgresJobStore::db_get_job(int64_t id) {
  return conn_.transact("read job", [&](pqxx::work& tx) {
    const pqxx::result rows = tx.exec_prepared("get_job", id);
    return rows.empty() ? std::optional<JobRecord>()
                        : std::optional<JobRecord>(job_from_postgres_row(rows[0]));
  });
}

Result<std::vector<JobRecord>> PostgresJobStore::db_list_jobs(std::optional<JobState> state,
                                                              int limit, int offset) {
  return conn_.transact("read jobs", [&](pqxx::work& tx) {
    return jobs_from(
        state ? tx.exec_prepared("list_jobs_in_state", job_state_name(*state), limit, offset)
              : tx.exec_prepared("list_jobs", limit, offset));
  });
}

Result<std::map<std::string, int64_t>> PostgresJobStore::db_count_by_state() {
  return conn_.transact("count jobs", [&](pqxx::work& tx) {
    std::map<std::string, int64_t> counts;
    for (const pqxx::row& row : tx.exec_prepared("count_jobs"))
      counts[row[0].c_str()] = row[1].as<int64_t>();
    return counts;
  });
}

Result<bool> PostgresJobStore::db_start_job(int64_t id, int64_t now_ms, const std::string& op) {
  if (Status s = check_not_fenced("start job"); !s) return s.error();
  return conn_.transact("start job", [&](pqxx::work& tx) {
    return tx.exec_prepared("start_job", id, now_ms, op, local_host()).affected_rows() == 1;
  });
}

Result<bool> PostgresJobStore::db_write_progress(int64_t id, int frames_done, int frames_total,
                                                 int frames_discarded) {
  return conn_.transact("update progress", [&](pqxx::work& tx) {
    return tx.exec_prepared("job_progress", id, frames_done, frames_total, frames_discarded,
                            local_host())
               .affected_rows() == 1;
  });
}

Result<bool> PostgresJobStore::db_finish_job(int64_t id, JobState state, int64_t now_ms,
                                             const std::string& error_code,
                                             const std::string& error_message,
                                             const std::optional<std::string>& result_text,
                                             const std::string& op) {
  if (Status s = check_not_fenced("finish job"); !s) return s.error();
  return conn_.transact("finish job", [&](pqxx::work& tx) {
    return tx.exec_prepared("finish_job", id, job_state_name(state), now_ms, error_code,
                            error_message, text_or_null(result_text), op, local_host())
               .affected_rows() == 1;
  });
}

Result<bool> PostgresJobStore::db_cancel_queued(int64_t id, int64_t now_ms, const std::string& op) {
  return conn_.transact("cancel job", [&](pqxx::work& tx) {
    return tx.exec_prepared("cancel_queued", id, now_ms, op).affected_rows() == 1;
  });
}

Result<JobStore::FinishedSummary> PostgresJobStore::db_finished_summary(int64_t id) {
  return conn_.transact("read finished job", [&](pqxx::work& tx) {
    FinishedSummary summary;
    const pqxx::result rows = tx.exec_prepared("finished_summary", id);
    if (!rows.empty()) {
      summary.kind = rows[0][0].c_str();
      summary.frames_done = rows[0][1].as<int>();
      summary.frames_total = rows[0][2].as<int>();
      summary.frames_discarded = rows[0][3].as<int>();
    }
    return summary;
  });
}

Result<int> PostgresJobStore::db_interrupt_unfinished(const std::string& message, int64_t now_ms) {
  return conn_.transact("interrupt jobs", [&](pqxx::work& tx) {
    return static_cast<int>(
        tx.exec_prepared("interrupt_unfinished", local_host(), now_ms, message).affected_rows());
  });
}

Status PostgresJobStore::db_put_latency(const LatencyRecord& record) {
  auto stored = conn_.transact("store latency", [&](pqxx::work& tx) {
    tx.exec_prepared("put_latency", local_host(), record.camera_id, record.latency_frames,
                     record.source, record.measured_ms, dump_json(record.details));
    return true;
  });
  if (!stored) return stored.error();
  return {};
}

Result<std::optional<LatencyRecord>> PostgresJobStore::db_latency(const std::string& camera_id) {
  return conn_.transact("read latency", [&](pqxx::work& tx) {
    std::optional<LatencyRecord> found;
    const pqxx::result rows = tx.exec_prepared("get_latency", local_host(), camera_id);
    if (!rows.empty()) {
      LatencyRecord& r = found.emplace();
      r.camera_id = camera_id;
      r.latency_frames = rows[0][0].as<int>();
      r.source = rows[0][1].c_str();
      r.measured_ms = rows[0][2].as<int64_t>();
      r.details = parse_stored_json(rows[0][3].c_str());
    }
    return found;
  });
}

}  // namespace camlab::service
