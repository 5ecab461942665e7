// The fleet's operations on PostgreSQL (fleet_store.h): hosts and leases, cameras, the
// queue of submitted jobs and claims, cancel requests, and the listener of the jobs
// trigger's notifications. Owned by the PostgresJobStore it belongs to, on a connection of
// its own.
//
// Thread-safe: one mutex around the fleet connection.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "service/store/fleet_store.h"
#include "service/store/postgres_connection.h"

namespace camlab::service {

class PostgresJobStore;
struct PostgresStoreOptions;

class PostgresFleet final : public FleetStore {
 public:
  PostgresFleet(PostgresJobStore& store, const PostgresStoreOptions& options);
  ~PostgresFleet() override;

  const std::string& host() const override { return host_; }
  Status hold_name(std::chrono::milliseconds lease) override;
  Status join(const std::string& url, std::chrono::milliseconds lease) override;
  Result<LeaseRenewal> renew() override;
  Status leave(const std::string& message) override;
  Result<std::vector<ExpiredHost>> expire_hosts() override;
  void set_fenced(bool fenced) override;
  bool fenced() const override;

  Status publish_cameras(const std::vector<FleetCamera>& cameras) override;
  Result<std::vector<FleetHost>> hosts() override;

  Result<JobRecord> submit(const std::string& host, const std::string& kind,
                           const std::string& camera_id, const nlohmann::json& request,
                           const std::string& folder_prefix, int frames_total) override;
  Result<std::vector<int64_t>> claim(const std::string& camera_id, int limit) override;
  Result<std::vector<std::string>> waiting_cameras() override;
  Result<int> waiting(const std::string& host, const std::string& camera_id) override;
  Result<std::vector<int64_t>> claimed_waiting() override;

  Result<bool> request_cancel(int64_t id) override;
  Result<std::vector<std::pair<int64_t, std::string>>> cancel_requests() override;

  Result<std::vector<JobRecord>> jobs_to_recover() override;
  Status set_recovered_frames(int64_t id, int frames) override;

  Result<std::unique_ptr<FleetListener>> listen() override;

 private:
  std::string next_op();
  // join() and hold_name(): the name's row, taken only from a holder that is not live or
  // is this identity (callers hold mutex_).
  Status take_name(const std::string& url, std::chrono::milliseconds lease, const char* what);

  PostgresJobStore& store_;
  const std::string host_;
  const std::string host_identity_;
  const postgres::ConnectOptions connect_;
  const std::chrono::milliseconds request_patience_;
  const std::string op_prefix_;
  std::mutex mutex_;
  postgres::Connection conn_;  // under mutex_
  std::string incarnation_;    // under mutex_; empty until joined
  uint64_t op_counter_ = 0;    // under mutex_
};

}  // namespace camlab::service
