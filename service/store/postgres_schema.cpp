#include "service/store/postgres_schema.h"

#include <string>

namespace camlab::service::postgres {

namespace {

// Any fixed number: the hosts of a fleet create the schema one at a time.
constexpr int64_t kSchemaLock = 0x63616d6c6162;  // "camlab"

const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS camlab_meta (
  key   text PRIMARY KEY,
  value text NOT NULL
);
CREATE TABLE IF NOT EXISTS jobs (
  id               bigserial PRIMARY KEY,
  kind             text NOT NULL,
  camera_id        text NOT NULL DEFAULT '',
  -- The host that runs the job and keeps its files; claimed once it has taken it.
  host             text NOT NULL DEFAULT '',
  claimed          boolean NOT NULL DEFAULT true,
  state            text NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed',
                                                  'cancelled', 'interrupted', 'device_lost')),
  request          text NOT NULL,
  folder           text NOT NULL DEFAULT '',
  created_ms       bigint NOT NULL,
  started_ms       bigint NOT NULL DEFAULT 0,
  finished_ms      bigint NOT NULL DEFAULT 0,
  frames_done      integer NOT NULL DEFAULT 0,
  frames_total     integer NOT NULL DEFAULT 0,
  frames_discarded integer NOT NULL DEFAULT 0,
  error_code       text NOT NULL DEFAULT '',
  error_message    text NOT NULL DEFAULT '',
  result           text,
  cancel_requested boolean NOT NULL DEFAULT false,
  -- The operation that made the insert and the last change (job_store.h, "op").
  create_op        text NOT NULL UNIQUE,
  last_op          text NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs (state);
CREATE INDEX IF NOT EXISTS jobs_waiting ON jobs (host, camera_id, id)
  WHERE state = 'queued' AND NOT claimed;
CREATE INDEX IF NOT EXISTS jobs_unfinished ON jobs (host)
  WHERE state IN ('queued', 'running');
-- Every state a job entered, in order: a job's history, and the proof that it ended once.
CREATE TABLE IF NOT EXISTS job_events (
  job_id bigint NOT NULL,
  state  text NOT NULL,
  host   text NOT NULL,
  at     timestamptz NOT NULL DEFAULT clock_timestamp()
);
CREATE INDEX IF NOT EXISTS job_events_by_job ON job_events (job_id);
CREATE TABLE IF NOT EXISTS devices (
  host           text NOT NULL,
  camera_id      text NOT NULL,
  latency_frames integer NOT NULL,
  latency_source text NOT NULL,
  measured_ms    bigint NOT NULL,
  details        text NOT NULL,
  PRIMARY KEY (host, camera_id)
);
CREATE TABLE IF NOT EXISTS hosts (
  name                 text PRIMARY KEY,
  url                  text NOT NULL,
  incarnation          text NOT NULL,
  state                text NOT NULL CHECK (state IN ('live', 'expired', 'left')),
  started_ms           bigint NOT NULL,
  previous_started_ms  bigint NOT NULL DEFAULT 0,
  lease_ms             integer NOT NULL,
  lease_until          timestamptz NOT NULL,
  renewed_at           timestamptz NOT NULL,
  clock_offset_us      bigint NOT NULL DEFAULT 0,
  clock_uncertainty_us bigint NOT NULL DEFAULT 0,
  host_identity        text NOT NULL DEFAULT ''
);
-- Databases made before hosts had identities (service/fleet/host_identity.h).
ALTER TABLE hosts ADD COLUMN IF NOT EXISTS host_identity text NOT NULL DEFAULT '';
CREATE TABLE IF NOT EXISTS cameras (
  host        text NOT NULL,
  camera_id   text NOT NULL,
  description text NOT NULL,
  available   boolean NOT NULL,
  running_job bigint NOT NULL DEFAULT 0,
  queued_jobs integer NOT NULL DEFAULT 0,
  PRIMARY KEY (host, camera_id)
);
-- Every new job, state change, progress row and cancel request is notified on
-- camlab_jobs (a host wakes to claim its jobs, or to cancel one; dashboards follow), and
-- every state entered is kept in job_events. A trigger, so that no writer can forget it.
CREATE OR REPLACE FUNCTION camlab_job_changed() RETURNS trigger AS $$
BEGIN
  IF TG_OP = 'INSERT' OR NEW.state IS DISTINCT FROM OLD.state THEN
    INSERT INTO job_events (job_id, state, host) VALUES (NEW.id, NEW.state, NEW.host);
  END IF;
  IF TG_OP = 'INSERT' OR NEW.state IS DISTINCT FROM OLD.state
     OR NEW.frames_done IS DISTINCT FROM OLD.frames_done
     OR NEW.cancel_requested IS DISTINCT FROM OLD.cancel_requested THEN
    PERFORM pg_notify('camlab_jobs', json_build_object(
      'id', NEW.id, 'state', NEW.state, 'host', NEW.host, 'camera_id', NEW.camera_id,
      'frames_done', NEW.frames_done, 'frames_total', NEW.frames_total,
      'frames_discarded', NEW.frames_discarded, 'cancel', NEW.cancel_requested)::text);
  END IF;
  RETURN NEW;
END
$$ LANGUAGE plpgsql;
CREATE OR REPLACE TRIGGER jobs_changed AFTER INSERT OR UPDATE ON jobs
  FOR EACH ROW EXECUTE FUNCTION camlab_job_changed();
)sql";

}  // namespace

Status create_schema(Connection& connection) {
  auto version = connection.transact("read the schema version", [](pqxx::work& tx) -> int {
    tx.exec_params("SELECT pg_advisory_xact_lock($1)", kSchemaLock);
    const pqxx::result exists = tx.exec("SELECT to_regclass('camlab_meta') IS NOT NULL");
    if (!exists[0][0].as<bool>()) return 0;
    const pqxx::result value =
        tx.exec("SELECT value FROM camlab_meta WHERE key = 'schema_version'");
    return value.empty() ? 0 : std::stoi(value[0][0].c_str());
  });
  if (!version) return version.error();
  if (*version > kSchemaVersion)
    return make_error("unsupported", "the database " + redacted_url(connection.options().url) +
                                         " has camlab schema version " + std::to_string(*version) +
                                         ", newer than this camlabd's " +
                                         std::to_string(kSchemaVersion));
  auto made = connection.transact("create the schema", [](pqxx::work& tx) -> int {
    tx.exec_params("SELECT pg_advisory_xact_lock($1)", kSchemaLock);
    tx.exec(kSchema);
    tx.exec_params(
        "INSERT INTO camlab_meta (key, value) VALUES ('schema_version', $1) "
        "ON CONFLICT (key) DO UPDATE SET value = EXCLUDED.value",
        std::to_string(kSchemaVersion));
    return 0;
  });
  if (!made) return made.error();
  return {};
}

}  // namespace camlab::service::postgres
