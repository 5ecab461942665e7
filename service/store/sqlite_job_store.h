// The job store of one camlabd: SQLite in the data folder (camlabd.sqlite), in WAL mode,
// with cached prepared statements (sqlite_statement.h) and the schema version in PRAGMA
// user_version. The shared behaviour (memory, observers, retries) is JobStore's
// (job_store.h); this class holds the statements.
//
// Thread-safe, as JobStore: one connection behind JobStore's mutex.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "base/result.h"
#include "service/store/job_store.h"
#include "service/store/sqlite_statement.h"

namespace camlab::service {

// 1: the first schema. 2: jobs.state may be 'device_lost' (a version-1 database is
// migrated when opened).
inline constexpr int kSchemaVersion = 2;

class SqliteJobStore final : public JobStore {
 public:
  // Opens (creating) the database at `path`, in WAL mode; refuses a newer schema.
  static Result<std::unique_ptr<JobStore>> open(const std::filesystem::path& path);
  ~SqliteJobStore() override;

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
  explicit SqliteJobStore(sqlite::Connection db);
  // The statement for `sql`, prepared on first use and kept (keyed by its text).
  Result<sqlite::Statement*> statement(std::string_view sql);
  // The cached statement `sql` with `args` bound, run to its end (execute: returns the rows
  // changed) or read row by row (query, query_jobs). `what` names the step in errors
  // ("database: start job: ..."). Defined in sqlite_job_store.cpp, the only user.
  template <class... Args>
  Result<int> execute(const char* what, const char* sql, const Args&... args);
  template <class OnRow, class... Args>
  Status query(const char* what, const char* sql, OnRow&& on_row, const Args&... args);
  template <class... Args>
  Result<std::vector<JobRecord>> query_jobs(const char* sql, const Args&... args);

  sqlite::Connection db_;
  // Declared after db_, so finalized before the connection closes.
  std::map<std::string, sqlite::Statement, std::less<>> statements_;
};

}  // namespace camlab::service
