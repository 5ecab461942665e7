// Opens the job store camlabd was configured with: SQLite in the data folder (the
// default), or PostgreSQL for a fleet (`--db postgresql://...`).
//
// Reentrant.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "base/result.h"
#include "service/store/job_store.h"

namespace camlab::service {

struct StoreConfig {
  // Empty: SQLite, DATA/camlabd.sqlite. postgresql://... or postgres://... (a libpq URI):
  // PostgreSQL, shared by a fleet.
  std::string db;
  std::filesystem::path data_dir;
  std::string host_name;      // this host's name in a fleet
  std::string host_identity;  // and who it is (service/fleet/host_identity.h)
  StoreRetry retry;
  std::chrono::milliseconds statement_timeout{10000};
};

bool is_postgres_url(const std::string& db);

Result<std::unique_ptr<JobStore>> open_job_store(const StoreConfig& config);

}  // namespace camlab::service
