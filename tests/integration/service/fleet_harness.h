// A fleet on one machine for tests and benchmarks: a throwaway PostgreSQL cluster
// (tests/support/pg_cluster.h) and camlabd hosts on loopback, each with its own data
// folder and port and two in-process virtual cameras, sharing one API token (a fleet's
// hosts redirect clients to each other). Every wait is bounded.
#pragma once

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon_harness.h"
#include "tests/support/pg_cluster.h"

namespace camlab::testing {

class FleetHarness {
 public:
  // `dir` holds the hosts' folders, the camera spec (`camera_spec` JSON) and the scene.
  FleetHarness(fs::path dir, const std::string& camera_spec) : dir_(std::move(dir)) {
    write_test_specs(dir_);
    std::ofstream(dir_ / "camera.json") << camera_spec;
    std::mt19937_64 rng(std::random_device{}());
    char hex[17];
    for (int i = 0; i < 4; ++i) {
      std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(rng()));
      token_ += hex;
    }
  }

  // The cluster and the database "camlab"; false with why.
  bool start_database(std::string* error, bool durable = false) {
    return cluster_.start(error, durable) && cluster_.create_database("camlab");
  }
  PgCluster& cluster() { return cluster_; }
  std::string db_url() const { return cluster_.url("camlab"); }

  // Starts host `name` (its folder DIR/NAME keeps its data across restarts) on `db`
  // (default: the cluster), with a lease of `lease_ms`, as --host-name `host_name`
  // (default: `name`; another folder with the same host name is a cloned machine).
  Daemon* start_host(const std::string& name, int lease_ms, const std::string& db = "",
                     std::vector<std::string> extra = {}, const std::string& host_name = "") {
    const fs::path folder = dir_ / name;
    fs::create_directories(folder / "data");
    const fs::path token = folder / "data" / "token";
    std::ofstream(token) << token_ << "\n";
    ::chmod(token.c_str(), 0600);
    auto& daemon = hosts_[name];
    if (!daemon) daemon = std::make_unique<Daemon>();
    // A host given --rig serves the rig's cameras instead of two of the fast camera.
    const bool rig = std::find(extra.begin(), extra.end(), "--rig") != extra.end();
    std::vector<std::string> args = {"--no-scan"};
    if (!rig)
      args.insert(args.end(),
                  {"--virtual-count", "2", "--camera-spec", (dir_ / "camera.json").string(),
                   "--scene", (dir_ / "scene.json").string()});
    args.insert(args.end(), {"--db", db.empty() ? db_url() : db, "--host-name",
                             host_name.empty() ? name : host_name, "--lease-ms",
                             std::to_string(lease_ms), "--rescan-ms", "0"});
    args.insert(args.end(), extra.begin(), extra.end());
    return daemon->start(folder, args) ? daemon.get() : nullptr;
  }
  Daemon* host(const std::string& name) {
    return hosts_.count(name) ? hosts_[name].get() : nullptr;
  }

  // GET /v1/fleet through `via` until `live` hosts are live with two available cameras
  // each, and no camera of a running host is still measuring its control latency (a job
  // would wait for it); the fleet's JSON, or null on timeout.
  nlohmann::json wait_live(const Daemon& via, size_t live,
                           std::chrono::seconds timeout = std::chrono::seconds(60),
                           int cameras_each = 2) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      const nlohmann::json fleet = via.get("/v1/fleet").json();
      size_t ready = 0;
      if (fleet.is_object())
        for (const auto& host : fleet["hosts"]) {
          int available = 0;
          for (const auto& camera : host["cameras"]) available += camera.value("available", false);
          ready += host["state"] == "live" && available == cameras_each;
        }
      if (ready == live && !measuring_latency()) return fleet;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return nullptr;
  }
  // Whether a camera of a running host is measuring its control latency.
  bool measuring_latency() {
    for (auto& [name, daemon] : hosts_) {
      if (daemon->pid() <= 0) continue;
      const nlohmann::json cameras = daemon->get("/v1/cameras").json();
      if (!cameras.is_object()) return true;
      for (const auto& camera : cameras["cameras"])
        if (camera.value("measuring_latency", false)) return true;
    }
    return false;
  }

  // The live cameras' fleet ids (CAMERA@HOST), from a /v1/fleet answer.
  static std::vector<std::string> camera_ids(const nlohmann::json& fleet) {
    std::vector<std::string> ids;
    for (const auto& host : fleet["hosts"])
      if (host["state"] == "live")
        for (const auto& camera : host["cameras"]) ids.push_back(camera["id"]);
    return ids;
  }

  // GET `path` on `via`, following one redirect to another host (same token).
  HttpResult get_following(const Daemon& via, const std::string& path) const {
    HttpResult r = via.get(path);
    if (r.status != 307) return r;
    const std::string location = r.headers["location"];
    const std::string prefix = "http://127.0.0.1:";
    if (location.rfind(prefix, 0) != 0) return r;
    const int port = std::atoi(location.c_str() + prefix.size());
    const size_t slash = location.find('/', prefix.size());
    return http(port, "GET", slash == std::string::npos ? "/" : location.substr(slash), token_);
  }

  // The last lines of every host's log (for a failure's message).
  std::string logs(size_t lines = 40) {
    std::string out;
    for (auto& [name, daemon] : hosts_) {
      const std::string text = daemon->log();
      size_t at = text.size();
      for (size_t n = 0; n <= lines && at != std::string::npos && at > 0; ++n)
        at = text.rfind('\n', at - 1);
      out += "---- " + name + "\n" + text.substr(at == std::string::npos ? 0 : at + 1);
    }
    return out;
  }

  const std::string& token() const { return token_; }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
  std::string token_;
  PgCluster cluster_;
  std::map<std::string, std::unique_ptr<Daemon>> hosts_;
};

}  // namespace camlab::testing
