// camlabd's lifetime: data folder, token, job store (interrupting jobs a crash left
// unfinished), cameras and their workers, compute worker, routes, listener, and the
// io_context on a small thread pool. SIGTERM/SIGINT stop it cleanly: the listener closes
// (no new connections), running captures are cancelled between frames and end
// "interrupted" with their frames kept, queued jobs end "interrupted", the workers join,
// and run_daemon returns 0.
#pragma once

#include <chrono>
#include <filesystem>
#include <string>

#include "service/http/http_limits.h"
#include "service/jobs/camera_set.h"

namespace camlab::service {

struct DaemonConfig {
  std::string listen = "127.0.0.1:8080";
  std::filesystem::path data_dir = "camlab-data";
  CameraSetOptions cameras;
  HttpLimits limits;
  int io_threads = 2;
  // The I/O threads run this much nicer than the rest of camlabd (Linux per-thread nice),
  // so on a loaded machine a capture's worker and frame writer win the CPU over status
  // requests (docs/service.md, "Threading model"); 0 runs them at the same priority.
  int io_nice = 5;
  int max_compute_jobs = 16;
  bool test_faults = false;
  // The job store: empty for SQLite in the data folder; a PostgreSQL URL for a fleet
  // (docs/fleet.md), with this host's name, the URL clients reach it at (empty: its listen
  // address) and its lease.
  std::string db;
  std::string host_name;
  std::string advertise_url;
  std::chrono::milliseconds lease{10000};
};

// Serves until SIGTERM or SIGINT; returns the process exit code (0 after a clean stop,
// 1 when it could not start, with the reason logged).
int run_daemon(const DaemonConfig& config);

}  // namespace camlab::service
