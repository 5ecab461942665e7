#include "service/store/open_job_store.h"

#include "service/store/postgres_job_store.h"
#include "service/store/sqlite_job_store.h"

namespace camlab::service {

bool is_postgres_url(const std::string& db) {
  return db.rfind("postgresql://", 0) == 0 || db.rfind("postgres://", 0) == 0;
}

Result<std::unique_ptr<JobStore>> open_job_store(const StoreConfig& config) {
  if (config.db.empty()) return SqliteJobStore::open(config.data_dir / "camlabd.sqlite");
  if (!is_postgres_url(config.db))
    return make_error("invalid_argument",
                      "--db must be a PostgreSQL URL (postgresql://USER@HOST:PORT/DATABASE); "
                      "without --db camlabd keeps its jobs in DATA/camlabd.sqlite");
  PostgresStoreOptions options;
  options.url = config.db;
  options.host = config.host_name;
  options.host_identity = config.host_identity;
  options.retry = config.retry;
  options.statement_timeout = config.statement_timeout;
  auto store = PostgresJobStore::open(options);
  if (!store) return store.error();
  return std::unique_ptr<JobStore>(std::move(*store));
}

}  // namespace camlab::service
