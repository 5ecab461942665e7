// Each job's history in a fleet's database: the states it entered, in order, as the jobs
// trigger keeps them in job_events (service/store/postgres_schema.cpp), read with psql. The
// tests' proof that a job ended once and ran at most once.
//
// Thread-compatible.
#pragma once

#include <cstdint>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/pg_cluster.h"

namespace camlab::testing {

// Job id -> its states in order; `ok` false when psql failed.
inline std::map<int64_t, std::vector<std::string>> job_histories(PgCluster& cluster,
                                                                 const std::string& database,
                                                                 bool* ok) {
  const std::string rows = cluster.sql(
      database, "SELECT job_id || ' ' || state FROM job_events ORDER BY job_id, at", ok);
  std::map<int64_t, std::vector<std::string>> states;
  std::istringstream lines(rows);
  int64_t id;
  std::string state;
  while (lines >> id >> state) states[id].push_back(state);
  return states;
}

}  // namespace camlab::testing
