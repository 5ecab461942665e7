#include "service/store/postgres_fleet.h"

#include <time.h>

#include <algorithm>
#include <utility>

#include "service/store/postgres_job_store.h"
#include "service/store/store_retry.h"

namespace camlab::service {

namespace {

const std::string kFleetJobColumns = kPostgresJobColumns;

int64_t realtime_us() {
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  return static_cast<int64_t>(now.tv_sec) * 1000000 + now.tv_nsec / 1000;
}

// The fleet connection's prepared statements: the insert that submit() shares with the
// job store, and the claim, which a busy fleet runs most.
void prepare_fleet_statements(pqxx::connection& conn) {
  prepare_postgres_job_statements(conn);
  // SKIP LOCKED: a row another transaction is claiming (or cancelling) is passed over,
  // not waited for, and never taken twice.
  conn.prepare("claim_jobs",
               "UPDATE jobs SET claimed = true WHERE id IN (SELECT id FROM jobs "
               "WHERE host = $1 AND camera_id = $2 AND state = 'queued' AND NOT claimed "
               "ORDER BY id LIMIT $3 FOR UPDATE SKIP LOCKED) RETURNING id");
}

// Receives one channel's notifications into a list.
class Receiver final : public pqxx::notification_receiver {
 public:
  struct Raw {
    std::string channel, payload;
    int pid = 0;
  };
  Receiver(pqxx::connection& conn, const std::string& channel, std::vector<Raw>* out)
      : pqxx::notification_receiver(conn, channel), out_(out) {}
  void operator()(const std::string& payload, int backend_pid) override {
    out_->push_back({channel(), payload, backend_pid});
  }

 private:
  std::vector<Raw>* out_;
};

// LISTENs on camlab_jobs and camlab_fleet on its own connection.
class PostgresListener final : public FleetListener {
 public:
  PostgresListener(const postgres::ConnectOptions& options, const PostgresJobStore& store)
      : store_(store),
        conn_(
            options,
            [this](pqxx::connection& conn) {
              for (const char* channel : {"camlab_jobs", "camlab_fleet"})
                receivers_.push_back(std::make_unique<Receiver>(conn, channel, &received_));
            },
            [this] { receivers_.clear(); }) {}

  Result<std::vector<FleetNotice>> wait(std::chrono::milliseconds timeout) override {
    const long seconds = static_cast<long>(timeout.count() / 1000);
    const long microseconds = static_cast<long>(timeout.count() % 1000) * 1000;
    Status waited = conn_.use("wait for notifications", [&](pqxx::connection& conn) {
      conn.await_notification(seconds, microseconds);
    });
    std::vector<FleetNotice> notices;
    const int own_pid = store_.backend_pid();
    for (Receiver::Raw& raw : received_)
      notices.push_back({raw.channel, parse_stored_json(raw.payload), raw.pid == own_pid});
    received_.clear();
    if (!waited && notices.empty()) return waited.error();
    return notices;
  }

 private:
  const PostgresJobStore& store_;
  // Declared before conn_, so alive when conn_'s close clears them.
  std::vector<std::unique_ptr<Receiver>> receivers_;
  std::vector<Receiver::Raw> received_;
  postgres::Connection conn_;
};

}  // namespace

PostgresFleet::PostgresFleet(PostgresJobStore& store, const PostgresStoreOptions& options)
    : store_(store),
      host_(options.host),
      host_identity_(options.host_identity),
      connect_{options.url, options.connect_timeout, options.statement_timeout},
      request_patience_(options.retry.request_patience),
      op_prefix_(new_operation_prefix()),
      conn_(connect_, prepare_fleet_statements) {}

PostgresFleet::~PostgresFleet() = default;

std::string PostgresFleet::next_op() {
  return op_prefix_ + "-submit-" + std::to_string(++op_counter_);
}

void PostgresFleet::set_fenced(bool fenced) { store_.set_fenced(fenced); }
bool PostgresFleet::fenced() const { return store_.fenced(); }

// The name's row for this host, as one guarded statement: a new row, or the existing one
// taken over only when it is this identity's or its holder is not live (left, expired, or
// its lease passed). RETURNING tells whether it was taken.
Status PostgresFleet::take_name(const std::string& url, std::chrono::milliseconds lease,
                                const char* what) {
  const std::string incarnation = new_operation_prefix();
  auto taken = conn_.transact(what, [&](pqxx::work& tx) -> Result<bool> {
    const pqxx::result row = tx.exec_params(
        "INSERT INTO hosts (name, url, incarnation, state, started_ms, lease_ms, lease_until, "
        "renewed_at, host_identity) VALUES ($1, $2, $3, 'live', $4, $5::integer, "
        "clock_timestamp() + $5::integer * interval '1 millisecond', clock_timestamp(), $6) "
        "ON CONFLICT (name) DO UPDATE SET url = EXCLUDED.url, incarnation = EXCLUDED.incarnation, "
        "state = 'live', started_ms = EXCLUDED.started_ms, lease_ms = EXCLUDED.lease_ms, "
        "lease_until = EXCLUDED.lease_until, renewed_at = EXCLUDED.renewed_at, "
        "host_identity = EXCLUDED.host_identity "
        "WHERE hosts.host_identity = EXCLUDED.host_identity OR hosts.host_identity = '' "
        "OR hosts.state <> 'live' OR hosts.lease_until <= clock_timestamp() RETURNING 1",
        host_, url, incarnation, unix_time_ms(), static_cast<int>(lease.count()), host_identity_);
    if (row.empty()) {
      const pqxx::result holder = tx.exec_params(
          "SELECT url, host_identity, (extract(epoch FROM lease_until - clock_timestamp()) * "
          "1000)::bigint FROM hosts WHERE name = $1",
          host_);
      std::string where = holder.empty() ? "" : holder[0][0].c_str();
      return make_error(
          "exists", "the host name '" + host_ + "' is held by another live camlabd (" +
                        (where.empty() ? std::string("starting") : "at " + where) + ", identity " +
                        (holder.empty() ? "" : holder[0][1].c_str()) + "; this one is " +
                        host_identity_ +
                        "): give each host its own --host-name (a cloned machine keeps the "
                        "system's host name)");
    }
    tx.exec_params("SELECT pg_notify('camlab_fleet', $1)",
                   dump_json({{"host", host_}, {"event", "joined"}}));
    return true;
  });
  if (!taken) return taken.error();
  if (!*taken) return taken->error();
  incarnation_ = incarnation;
  return {};
}

Status PostgresFleet::hold_name(std::chrono::milliseconds lease) {
  std::lock_guard lock(mutex_);
  return take_name("", lease, "take the host name");
}

Status PostgresFleet::join(const std::string& url, std::chrono::milliseconds lease) {
  std::lock_guard lock(mutex_);
  return take_name(url, lease, "join the fleet");
}

Result<LeaseRenewal> PostgresFleet::renew() {
  std::lock_guard lock(mutex_);
  if (incarnation_.empty()) return LeaseRenewal{};
  return conn_.transact("renew the lease", [&](pqxx::work& tx) {
    // The offset of this host's clock from the server's, NTP-style: the server's time
    // read between two of ours is taken as at their midpoint.
    const int64_t before_us = realtime_us();
    const pqxx::row server =
        tx.exec1("SELECT (extract(epoch FROM clock_timestamp()) * 1000000)::bigint");
    const int64_t after_us = realtime_us();
    LeaseRenewal renewal;
    renewal.clock_offset_us = (before_us + after_us) / 2 - server[0].as<int64_t>();
    renewal.clock_uncertainty_us = (after_us - before_us + 1) / 2;
    // A lease that has passed is not renewed, even if no host has expired it yet: its
    // jobs may be being interrupted right now.
    renewal.renewed =
        tx.exec_params(
              "UPDATE hosts SET lease_until = clock_timestamp() + lease_ms * "
              "interval '1 millisecond', renewed_at = clock_timestamp(), "
              "clock_offset_us = $3, clock_uncertainty_us = $4 "
              "WHERE name = $1 AND incarnation = $2 AND state = 'live' "
              "AND lease_until > clock_timestamp()",
              host_, incarnation_, renewal.clock_offset_us, renewal.clock_uncertainty_us)
            .affected_rows() == 1;
    return renewal;
  });
}

Status PostgresFleet::leave(const std::string& message) {
  std::lock_guard lock(mutex_);
  auto left = conn_.transact("leave the fleet", [&](pqxx::work& tx) {
    tx.exec_params(
        "UPDATE hosts SET state = 'left', lease_until = clock_timestamp() "
        "WHERE name = $1 AND incarnation = $2",
        host_, incarnation_);
    tx.exec_params(
        "UPDATE jobs SET state = 'interrupted', finished_ms = $2, error_code = 'interrupted', "
        "error_message = $3 WHERE host = $1 AND state IN ('queued', 'running')",
        host_, unix_time_ms(), message);
    tx.exec_params("SELECT pg_notify('camlab_fleet', $1)",
                   dump_json({{"host", host_}, {"event", "left"}}));
    return true;
  });
  if (!left) return left.error();
  incarnation_.clear();
  return {};
}

Result<std::vector<ExpiredHost>> PostgresFleet::expire_hosts() {
  std::lock_guard lock(mutex_);
  return conn_.transact("expire leases", [&](pqxx::work& tx) {
    std::vector<ExpiredHost> expired;
    for (const pqxx::row& row :
         tx.exec("UPDATE hosts SET state = 'expired' "
                 "WHERE state = 'live' AND lease_until < clock_timestamp() RETURNING name"))
      expired.push_back({row[0].c_str(), {}});
    // The jobs of every host that is not live: those just expired, and any submitted to a
    // host as it expired or left. Each UPDATE is conditional, so a job is interrupted once
    // however many hosts sweep at the same time.
    const pqxx::result jobs = tx.exec_params(
        "UPDATE jobs SET state = 'interrupted', finished_ms = $1, error_code = 'interrupted', "
        "error_message = CASE h.state WHEN 'left' THEN 'host ' || h.name || ' left the fleet' "
        "ELSE 'host ' || h.name || ' stopped renewing its lease (killed, crashed or cut off "
        "from the database)' END || ' while this job was queued or running; the frames "
        "written stay on it' "
        "FROM hosts h WHERE h.name = jobs.host AND h.state <> 'live' "
        "AND jobs.state IN ('queued', 'running') RETURNING jobs.id, jobs.host",
        unix_time_ms());
    for (const pqxx::row& row : jobs) {
      const std::string host = row[1].c_str();
      auto it = std::find_if(expired.begin(), expired.end(),
                             [&](const ExpiredHost& e) { return e.name == host; });
      if (it == expired.end()) it = expired.insert(expired.end(), {host, {}});
      it->jobs_interrupted.push_back(row[0].as<int64_t>());
    }
    if (!expired.empty())
      tx.exec_params("SELECT pg_notify('camlab_fleet', $1)",
                     dump_json({{"host", host_}, {"event", "expired"}}));
    return expired;
  });
}

Status PostgresFleet::publish_cameras(const std::vector<FleetCamera>& cameras) {
  std::lock_guard lock(mutex_);
  auto published = conn_.transact("publish cameras", [&](pqxx::work& tx) {
    tx.exec_params("DELETE FROM cameras WHERE host = $1", host_);
    for (const FleetCamera& camera : cameras)
      tx.exec_params(
          "INSERT INTO cameras (host, camera_id, description, available, running_job, "
          "queued_jobs) VALUES ($1, $2, $3, $4, $5, $6)",
          host_, camera.camera_id, dump_json(camera.description), camera.available,
          camera.running_job, camera.queued_jobs);
    return true;
  });
  if (!published) return published.error();
  return {};
}

Result<std::vector<FleetHost>> PostgresFleet::hosts() {
  std::lock_guard lock(mutex_);
  return conn_.transact("read the fleet", [&](pqxx::work& tx) {
    std::vector<FleetHost> hosts;
    for (const pqxx::row& row :
         tx.exec("SELECT name, url, state, started_ms, lease_ms, "
                 "(extract(epoch FROM lease_until - clock_timestamp()) * 1000)::bigint, "
                 "(extract(epoch FROM clock_timestamp() - renewed_at) * 1000)::bigint, "
                 "clock_offset_us, clock_uncertainty_us FROM hosts ORDER BY name")) {
      FleetHost host;
      host.name = row[0].c_str();
      host.url = row[1].c_str();
      host.state = row[2].c_str();
      host.started_ms = row[3].as<int64_t>();
      host.lease_ms = row[4].as<int>();
      host.lease_remaining_ms = row[5].as<int64_t>();
      host.renewed_ago_ms = row[6].as<int64_t>();
      host.clock_offset_us = row[7].as<int64_t>();
      host.clock_uncertainty_us = row[8].as<int64_t>();
      hosts.push_back(std::move(host));
    }
    for (const pqxx::row& row :
         tx.exec("SELECT host, camera_id, description, available, running_job, queued_jobs "
                 "FROM cameras ORDER BY host, camera_id")) {
      FleetCamera camera{row[0].c_str(),    row[1].c_str(),       parse_stored_json(row[2].c_str()),
                         row[3].as<bool>(), row[4].as<int64_t>(), row[5].as<int>()};
      for (FleetHost& host : hosts)
        if (host.name == camera.host) host.cameras.push_back(std::move(camera));
    }
    return hosts;
  });
}

Result<JobRecord> PostgresFleet::submit(const std::string& host, const std::string& kind,
                                        const std::string& camera_id, const nlohmann::json& request,
                                        const std::string& folder_prefix, int frames_total) {
  const std::string request_text = dump_json(request);
  const int64_t created_ms = unix_time_ms();
  std::string op;
  {
    std::lock_guard lock(mutex_);
    op = next_op();
  }
  return retry_while_unavailable(request_patience_, mutex_, [&]() -> Result<JobRecord> {
    auto inserted = conn_.transact("submit job", [&](pqxx::work& tx) {
      return tx.exec_prepared("insert_job", kind, camera_id, host, false, request_text,
                              folder_prefix, created_ms, frames_total, op, true);
    });
    if (!inserted) return inserted.error();
    if (inserted->empty())
      return make_error("host_unavailable",
                        "host " + host +
                            " is not serving (its lease has passed or it left the "
                            "fleet); GET /v1/fleet lists the hosts");
    JobRecord job;
    job.id = (*inserted)[0][0].as<int64_t>();
    job.folder = (*inserted)[0][1].c_str();
    job.kind = kind;
    job.camera_id = camera_id;
    job.host = host;
    job.request = request;
    job.created_ms = created_ms;
    job.frames_total = frames_total;
    return job;
  });
}

Result<std::vector<int64_t>> PostgresFleet::claim(const std::string& camera_id, int limit) {
  std::lock_guard lock(mutex_);
  return conn_.transact("claim jobs", [&](pqxx::work& tx) {
    std::vector<int64_t> ids;
    for (const pqxx::row& row : tx.exec_prepared("claim_jobs", host_, camera_id, limit))
      ids.push_back(row[0].as<int64_t>());
    std::sort(ids.begin(), ids.end());  // RETURNING has no order: run them as submitted
    return ids;
  });
}

Result<std::vector<std::string>> PostgresFleet::waiting_cameras() {
  std::lock_guard lock(mutex_);
  return conn_.transact("find waiting jobs", [&](pqxx::work& tx) {
    std::vector<std::string> cameras;
    for (const pqxx::row& row :
         tx.exec_params("SELECT DISTINCT camera_id FROM jobs "
                        "WHERE host = $1 AND state = 'queued' AND NOT claimed",
                        host_))
      cameras.push_back(row[0].c_str());
    return cameras;
  });
}

Result<int> PostgresFleet::waiting(const std::string& host, const std::string& camera_id) {
  std::lock_guard lock(mutex_);
  return conn_.transact("count waiting jobs", [&](pqxx::work& tx) {
    return tx
        .exec_params1(
            "SELECT count(*) FROM jobs WHERE host = $1 AND camera_id = $2 "
            "AND state = 'queued' AND NOT claimed",
            host, camera_id)[0]
        .as<int>();
  });
}

Result<std::vector<int64_t>> PostgresFleet::claimed_waiting() {
  std::lock_guard lock(mutex_);
  return conn_.transact("find claimed jobs", [&](pqxx::work& tx) {
    std::vector<int64_t> ids;
    // Only the kinds a camera worker runs: a compute job (calibration, analysis) waits
    // queued and claimed behind the one computing, and a synchronised capture's parent or a
    // calibration session is queued for the moment before it starts; none is a camera's.
    for (const pqxx::row& row :
         tx.exec_params("SELECT id FROM jobs WHERE host = $1 AND state = 'queued' AND claimed "
                        "AND kind IN ('capture', 'latency_probe') ORDER BY id",
                        host_))
      ids.push_back(row[0].as<int64_t>());
    return ids;
  });
}

Result<bool> PostgresFleet::request_cancel(int64_t id) {
  std::lock_guard lock(mutex_);
  return conn_.transact("request a cancel", [&](pqxx::work& tx) {
    return tx.exec_params(
                 "UPDATE jobs SET cancel_requested = true "
                 "WHERE id = $1 AND state = 'running'",
                 id)
               .affected_rows() == 1;
  });
}

Result<std::vector<std::pair<int64_t, std::string>>> PostgresFleet::cancel_requests() {
  std::lock_guard lock(mutex_);
  return conn_.transact("read cancel requests", [&](pqxx::work& tx) {
    std::vector<std::pair<int64_t, std::string>> requests;
    for (const pqxx::row& row :
         tx.exec_params("SELECT id, camera_id FROM jobs WHERE host = $1 AND state = 'running' "
                        "AND cancel_requested",
                        host_))
      requests.emplace_back(row[0].as<int64_t>(), row[1].c_str());
    return requests;
  });
}

Result<std::vector<JobRecord>> PostgresFleet::jobs_to_recover() {
  std::lock_guard lock(mutex_);
  return conn_.transact("find jobs to recover", [&](pqxx::work& tx) {
    std::vector<JobRecord> jobs;
    for (const pqxx::row& row : tx.exec_params(
             "SELECT " + kFleetJobColumns +
                 " FROM jobs WHERE host = $1 AND folder <> '' AND (state IN ('queued', "
                 "'running') OR (state = 'interrupted' AND finished_ms >= COALESCE((SELECT "
                 "started_ms FROM hosts WHERE name = $1), 0))) ORDER BY id",
             host_))
      jobs.push_back(job_from_postgres_row(row));
    return jobs;
  });
}

Status PostgresFleet::set_recovered_frames(int64_t id, int frames) {
  std::lock_guard lock(mutex_);
  auto set = conn_.transact("store recovered frames", [&](pqxx::work& tx) {
    return tx
        .exec_params(
            "UPDATE jobs SET frames_done = $2 WHERE id = $1 AND host = $3 "
            "AND state = 'interrupted' AND frames_done < $2",
            id, frames, host_)
        .affected_rows();
  });
  if (!set) return set.error();
  return {};
}

Result<std::unique_ptr<FleetListener>> PostgresFleet::listen() {
  return std::unique_ptr<FleetListener>(new PostgresListener(connect_, store_));
}

}  // namespace camlab::service
