// The PostgreSQL schema of a fleet's job store, created on first use by whichever host
// comes first (under an advisory lock, so hosts starting together do not race), with its
// version in camlab_meta. docs/fleet.md describes the tables.
//
// Reentrant: functions of their connection or transaction.
#pragma once

#include <pqxx/pqxx>

#include "base/result.h"
#include "service/store/postgres_connection.h"

namespace camlab::service::postgres {

// 1: jobs, job_events, devices, hosts, cameras and the jobs trigger.
inline constexpr int kSchemaVersion = 1;

// Creates the schema when missing; "unsupported" when the database's is newer.
Status create_schema(Connection& connection);

}  // namespace camlab::service::postgres
