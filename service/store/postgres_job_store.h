// The job store on PostgreSQL, shared by the hosts of a fleet (`camlabd --db
// postgresql://...`; docs/fleet.md). The same operations as the SQLite store
// (job_store.h: the shared test suite runs on both), with these differences:
//
// - Every row says which host runs the job (`host`); create() makes a job this host runs
//   and has taken (claimed), as the API and the workers did on one host. A job submitted
//   for another host's camera waits unclaimed until that host claims it (fleet_store.h).
// - start(), progress() and finish() touch only this host's claimed jobs, and
//   interrupt_unfinished() only those (another host's queue is not this host's to end).
//   Listing, reading and counting see the whole fleet's jobs; cancel_queued() cancels any
//   host's queued job.
// - Latencies are per host and camera (two hosts' virtual cameras share an id).
// - Every write names its operation (`last_op`): a write tried again after the connection
//   broke mid-commit finds its own first attempt and does not count as refused.
//
// Thread-safe, as JobStore: the job connection behind JobStore's mutex; the fleet's own
// operations (postgres_fleet.h) use a second connection.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <string>

#include "base/result.h"
#include "service/store/fleet_store.h"
#include "service/store/job_store.h"
#include "service/store/postgres_connection.h"

namespace camlab::service {

class PostgresFleet;

struct PostgresStoreOptions {
  std::string url;   // postgresql://USER@HOST:PORT/DB (libpq: a password from ~/.pgpass)
  std::string host;  // this host's name in the fleet (not empty)
  // Who holds the name (service/fleet/host_identity.h): a live host of the same name and
  // another identity keeps it (FleetStore::hold_name).
  std::string host_identity;
  StoreRetry retry;
  std::chrono::milliseconds connect_timeout{3000};
  std::chrono::milliseconds statement_timeout{10000};
};

class PostgresJobStore final : public JobStore {
 public:
  // Connects (trying again for retry.worker_patience while the server is unreachable, so
  // that hosts started with the database come up) and creates or checks the schema.
  static Result<std::unique_ptr<PostgresJobStore>> open(const PostgresStoreOptions& options);
  ~PostgresJobStore() override;

  FleetStore* fleet() override;
  // The server process of the job connection (its notifications carry it).
  int backend_pid() const { return conn_.backend_pid(); }
  // See FleetStore::set_fenced.
  void set_fenced(bool fenced) { fenced_ = fenced; }
  bool fenced() const { return fenced_.load(); }

 protected:
  Result<JobRecord> db_insert_job(const NewJob& job, const std::string& op) override;
  Result<std::optional<JobRecord>> db_get_job(int64_t id) override;
  Result<std::vector<JobRecord>> db_list_jobs(std::optional<JobState> state, int limit,
                                              int offset) override;
  Result<std::map<std::string, int64_t>> db_count_by_state() override;
  Result<bool> db_start_job(int64_t id, int64_t now_ms, const std::string& op) override;
  Result<bool> db_write_progress(int64_t id, int frames_done, int frames_total,
                                 int frames_discarded) override;
  Result<bool> db_finish_job(int64_t id, JobState state, int64_t now_ms,
                             const std::string& error_code, const std::string& error_message,
                             const std::optional<std::string>& result_text,
                             const std::string& op) override;
  Result<bool> db_cancel_queued(int64_t id, int64_t now_ms, const std::string& op) override;
  Result<FinishedSummary> db_finished_summary(int64_t id) override;
  Result<int> db_interrupt_unfinished(const std::string& message, int64_t now_ms) override;
  Status db_put_latency(const LatencyRecord& record) override;
  Result<std::optional<LatencyRecord>> db_latency(const std::string& camera_id) override;

 private:
  explicit PostgresJobStore(const PostgresStoreOptions& options);
  // database_unavailable while fenced: this host may no longer write as the jobs' runner.
  Status check_not_fenced(const char* what) const;

  const PostgresStoreOptions options_;
  postgres::Connection conn_;
  std::atomic<bool> fenced_{false};
  std::unique_ptr<PostgresFleet> fleet_;
};

// A pqxx row of the jobs table's columns in the order of kPostgresJobColumns.
inline constexpr const char* kPostgresJobColumns =
    "id, kind, camera_id, host, state, request, folder, created_ms, started_ms, finished_ms, "
    "frames_done, frames_total, frames_discarded, error_code, error_message, result";
JobRecord job_from_postgres_row(const pqxx::row& row);
// The job statements (insert_job, get_job, ...), prepared on every (re)connect of a
// connection that uses them. $-parameters are typed by PostgreSQL from their use.
void prepare_postgres_job_statements(pqxx::connection& conn);

}  // namespace camlab::service
