#include "service/daemon.h"

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <future>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>

#include "base/log.h"
#include "service/api/auth.h"
#include "service/api/router.h"
#include "service/api/service_context.h"
#include "service/fleet/fleet.h"
#include "service/fleet/host_identity.h"
#include "service/fleet/local_sync_site.h"
#include "service/fleet/sync_captures.h"
#include "service/http/listener.h"
#include "service/jobs/calibration_sessions.h"
#include "service/jobs/compute_jobs.h"
#include "service/jobs/job_events.h"
#include "service/jobs/job_recovery.h"
#include "service/jobs/job_waiters.h"
#include "service/live/live_hub.h"
#include "service/metrics.h"
#include "service/store/job_store.h"
#include "service/store/open_job_store.h"

namespace camlab::service {
namespace {

// Raises the calling thread's nice value by `by` (Linux: nice is per thread). Raising it
// needs no privilege; a failure only costs the capture its protection, so it is logged.
void lower_this_thread_priority(int by) {
  if (by <= 0) return;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, tid);
  if (errno == 0 && ::setpriority(PRIO_PROCESS, tid, std::min(now + by, 19)) == 0) return;
  log_warning(log::Category::kDaemon, "I/O thread priority not lowered by %d: %s", by,
              std::strerror(errno));
}

}  // namespace

namespace net = boost::asio;
namespace fs = std::filesystem;

namespace {

Result<fs::path> prepare_data_dir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    return make_error("io_error",
                      "cannot create the data folder " + dir.string() + ": " + ec.message());
  const fs::path canonical = fs::canonical(dir, ec);
  if (ec)
    return make_error("io_error",
                      "cannot resolve the data folder " + dir.string() + ": " + ec.message());
  for (const char* sub : {"captures", "calibrations", "analyses"}) {
    fs::create_directories(canonical / sub, ec);
    if (ec)
      return make_error("io_error",
                        "cannot create " + (canonical / sub).string() + ": " + ec.message());
  }
  return canonical;
}

}  // namespace

int run_daemon(const DaemonConfig& config) {
  // Writes to a socket the peer closed must fail with EPIPE, not kill the daemon.
  std::signal(SIGPIPE, SIG_IGN);

  auto endpoint = parse_listen_address(config.listen);
  if (!endpoint) {
    log_error(log::Category::kDaemon, "%s", endpoint.error().message.c_str());
    return 1;
  }
  auto data_dir = prepare_data_dir(config.data_dir);
  if (!data_dir) {
    log_error(log::Category::kDaemon, "%s", data_dir.error().message.c_str());
    return 1;
  }
  auto token = load_or_create_token(*data_dir);
  if (!token) {
    log_error(log::Category::kDaemon, "%s", token.error().message.c_str());
    return 1;
  }
  if (!token->warning.empty()) log_warning(log::Category::kDaemon, "%s", token->warning.c_str());
  if (token->created) {
    // Named, never printed: a daemon's output ends up in journals and CI logs, which
    // the token must not.
    std::printf(
        "camlabd: created an API token in %s (mode 0600); clients send it as "
        "\"Authorization: Bearer $(cat %s)\"\n",
        (*data_dir / "token").c_str(), (*data_dir / "token").c_str());
    std::fflush(stdout);
  }

  StoreConfig store_config;
  store_config.db = config.db;
  store_config.data_dir = *data_dir;
  store_config.host_name = config.host_name;
  if (!config.db.empty()) {  // a fleet host: who it is besides its name
    auto identity = load_host_identity(*data_dir);
    if (!identity) {
      log_error(log::Category::kDaemon, "%s", identity.error().message.c_str());
      return 1;
    }
    store_config.host_identity = *identity;
  }
  // A statement longer than half the lease is of no use to a fleet host (its lease would
  // pass meanwhile): that long, then the connection is taken for dead.
  store_config.statement_timeout = std::clamp(config.lease / 2, std::chrono::milliseconds(1000),
                                              std::chrono::milliseconds(10000));
  auto store = open_job_store(store_config);
  if (!store) {
    log_error(log::Category::kDaemon, "%s", store.error().message.c_str());
    return 1;
  }
  // A fleet host takes its name before it touches any job of that name: a second camlabd
  // started with a live host's name (a cloned machine) stops here, and the live one's jobs
  // are left alone (they were interrupted below, 0.3 s after the clone started).
  if (FleetStore* shared = (*store)->fleet())
    if (Status held = shared->hold_name(config.lease); !held) {
      log_error(log::Category::kDaemon, "cannot start as a fleet host: %s",
                held.error().message.c_str());
      return 1;
    }
  // The folders are the truth: the jobs the last run left unfinished get their folders
  // recovered and their frame counts from them, then are marked interrupted.
  if (auto recovered = recover_unfinished_jobs(**store, *data_dir); !recovered)
    log_warning(log::Category::kDaemon, "recovering unfinished jobs: %s",
                recovered.error().message.c_str());
  auto interrupted = (*store)->interrupt_unfinished(
      "camlabd stopped while this job was queued or running (crash or kill); the frames written "
      "are kept");
  if (interrupted && *interrupted > 0)
    log_warning(log::Category::kDaemon, "%d unfinished job(s) from the last run marked interrupted",
                *interrupted);

  Metrics metrics;
  // Finished jobs are counted where their state is stored, so the counters and the job
  // states cannot disagree (a job cancelled while queued, or cancelled while its outcome
  // was being written, is counted once, as what the database says).
  (*store)->set_finish_observer([&metrics](const std::string& kind, JobState state) {
    metrics.count_job_finished(kind, job_state_name(state));
  });
  // Job changes go to the event streams (GET /v1/events) and the long-polls
  // (GET /v1/jobs/{id}?wait=) as they are stored. Long-polls are capped at a quarter of the
  // connections, so they cannot hold all of them.
  JobEvents events;
  JobWaiters waiters(**store, std::max(1, config.limits.max_connections / 4));
  (*store)->set_change_observer([&events, &waiters](const JobChange& change) {
    events.publish(change);
    waiters.notify(change);
  });
  // The live view's rendering gives way to captures, as the HTTP threads do.
  LiveHub live([io_nice = config.io_nice] { lower_this_thread_priority(io_nice); });
  CameraSetOptions camera_options = config.cameras;
  camera_options.worker.data_dir = *data_dir;
  auto cameras = CameraSet::create(camera_options, **store, metrics);
  if (!cameras) {
    log_error(log::Category::kDaemon, "%s", cameras.error().message.c_str());
    return 1;
  }
  ComputeWorker compute(*data_dir, **store, metrics, config.max_compute_jobs);
  CalibrationSessions sessions(*data_dir, **store, **cameras);

  TokenAuth auth(token->token);
  Router router(&auth, &metrics);
  router.hide_data_dir(*data_dir);
  // A fleet host (PostgreSQL): joins once it serves, below.
  std::unique_ptr<Fleet> fleet;
  if (FleetStore* shared = (*store)->fleet())
    fleet = std::make_unique<Fleet>(*shared, **store, **cameras, compute,
                                    FleetOptions{config.host_name, "", config.lease},
                                    config.cameras.worker.max_queued_jobs);
  ServiceContext context{*data_dir, store->get(),       cameras->get(), &compute,
                         &metrics,  config.test_faults, &sessions,      &waiters};
  context.live = &live;
  context.events = &events;
  context.fleet = fleet.get();
  // One camlabd alone synchronises its own cameras (a rig on one machine, SQLite).
  std::unique_ptr<LocalSyncSite> local_site;
  std::unique_ptr<SyncCaptures> local_sync;
  if (!fleet) {
    local_site = std::make_unique<LocalSyncSite>(**store, **cameras);
    local_sync = std::make_unique<SyncCaptures>(*local_site);
    context.sync = local_sync.get();
  }
  add_all_routes(router, context);

  net::io_context ioc(config.io_threads);
  auto listener = Listener::create(ioc, *endpoint, router, config.limits);
  if (!listener) {
    log_error(log::Category::kDaemon, "%s", listener.error().message.c_str());
    return 1;
  }

  (*cameras)->start();
  if (local_sync) local_sync->start();
  compute.start();
  sessions.start();
  waiters.start();
  events.start();
  live.start();
  const auto workers = (*cameras)->workers();
  for (const auto& worker : workers) {
    const CameraSnapshot s = worker->snapshot();
    log_info(log::Category::kDaemon, "camera %s: %s (%s, %s)%s%s", s.identity.id.c_str(),
             s.identity.name.c_str(), s.identity.path.c_str(), s.transport.c_str(),
             s.available ? "" : " unavailable: ", s.available ? "" : s.unavailable_reason.c_str());
  }
  if (workers.empty())
    log_warning(log::Category::kDaemon,
                "no cameras yet (none found, and the virtual camera is off); cameras plugged in "
                "later are served");

  std::promise<int> stop_signal;
  net::signal_set signals(ioc, SIGINT, SIGTERM);
  signals.async_wait([&stop_signal](const boost::system::error_code& ec, int signal_number) {
    if (!ec) stop_signal.set_value(signal_number);
  });

  (*listener)->run();
  const auto bound = (*listener)->local_endpoint();
  if (!bound.address().is_loopback())
    log_warning(log::Category::kDaemon,
                "listening on %s, which other hosts can reach: the API token and the frames "
                "travel in clear; bind to 127.0.0.1 (the default) or put a TLS proxy in front",
                bound.address().to_string().c_str());
  log_info(log::Category::kDaemon,
           "listening on http://%s:%u (data %s, %zu camera(s), %d I/O threads%s)",
           bound.address().to_string().c_str(), bound.port(), data_dir->c_str(), workers.size(),
           config.io_threads, config.test_faults ? ", TEST FAULT INJECTION ENABLED" : "");

  std::vector<std::thread> pool;
  for (int i = 0; i < config.io_threads; ++i)
    pool.emplace_back([&ioc, io_nice = config.io_nice] {
      lower_this_thread_priority(io_nice);
      ioc.run();
    });

  // A fleet host joins once it serves (its URL has the port bound). A host that cannot
  // join stops at once, exit status 1.
  int exit_code = 0;
  if (fleet) {
    const auto at = (*listener)->local_endpoint();
    const std::string url = !config.advertise_url.empty() ? config.advertise_url
                                                          : "http://" + at.address().to_string() +
                                                                ":" + std::to_string(at.port());
    if (config.advertise_url.empty() && at.address().is_loopback())
      log_warning(log::Category::kDaemon,
                  "fleet: this host advertises %s, a loopback address: hosts and clients on other "
                  "machines cannot reach its frames there, and a client that follows a redirect "
                  "with its token (curl --location-trusted) would send the token to its own "
                  "loopback; give --advertise-url (docs/fleet.md)",
                  url.c_str());
    if (Status joined = fleet->start(url); !joined) {
      log_error(log::Category::kDaemon, "cannot join the fleet: %s",
                joined.error().message.c_str());
      exit_code = 1;
      std::raise(SIGTERM);
    }
  }

  const int signal_number = stop_signal.get_future().get();
  log_info(log::Category::kDaemon,
           "%s received: stopping (no new connections; running jobs are interrupted, frames kept)",
           signal_number == SIGTERM ? "SIGTERM" : "SIGINT");
  if (fleet) fleet->stop_taking_jobs();
  (*listener)->stop();
  // The streams end first (their connections close), then what feeds them.
  live.stop();
  events.stop();
  waiters.stop();
  sessions.stop();
  (*cameras)->stop();
  compute.stop();
  if (local_sync) {
    // Its captures ended with the cameras; a synchronised capture still waiting for them
    // ends interrupted too (everything else has ended by now).
    local_sync->stop();
    (void)(*store)->interrupt_unfinished(
        "camlabd stopped while this synchronised capture was running; the frames written are "
        "kept");
  }
  if (fleet)
    fleet->leave("camlabd on host " + config.host_name +
                 " stopped while this job was queued or running; the frames written "
                 "are kept on it");
  ioc.stop();
  for (auto& t : pool) t.join();
  log_info(log::Category::kDaemon, "stopped");
  return exit_code;
}

}  // namespace camlab::service
