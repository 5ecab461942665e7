// How fast jobs are handed to camera workers through the job store: jobs claimed per
// second and claim latency (p50/p99), for SQLite (one camlabd) and PostgreSQL with 1 and 3
// hosts (docs/BENCHMARKS.md, "Fleet: claiming jobs"). A benchmark: it prints, never fails.
//
// A job here is empty (started and finished at once), so what is measured is the store's
// part of a job's journey, as camlabd's paths make it:
// - SQLite, one host: the API creates the job and queues its id on the camera's worker
//   (memory), whose thread starts it (queued -> running) and finishes it.
// - PostgreSQL: the API of a random host submits the job for a camera of a random host;
//   that host hears of it (LISTEN/NOTIFY, or its 500 ms poll), claims it (UPDATE ... FOR
//   UPDATE SKIP LOCKED), and the camera's worker starts it and finishes it. Each host has
//   its own connections (job store, fleet, listener), as a camlabd does; two cameras each.
//
// "Claimed per second": a backlog of jobs drained by every camera at once. "Claim
// latency": from the submission's return to the start's, with jobs submitted at a steady
// rate well below that throughput.
//
// Usage: fleet_claim_bench [--backlog N] [--rate JOBS_PER_S] [--seconds S]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "service/store/fleet_store.h"
#include "service/store/job_store.h"
#include "service/store/open_job_store.h"
#include "tests/support/pg_cluster.h"

namespace {

using namespace camlab::service;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

constexpr int kCamerasPerHost = 2;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<size_t>(p * values.size()))];
}

// When each job was submitted and started (by id), filled by the threads.
struct Timings {
  std::mutex mutex;
  std::map<int64_t, Clock::time_point> submitted, started;
  void submit(int64_t id) {
    std::lock_guard lock(mutex);
    submitted[id] = Clock::now();
  }
  void start(int64_t id) {
    std::lock_guard lock(mutex);
    started[id] = Clock::now();
  }
  std::vector<double> latencies_ms() {
    std::lock_guard lock(mutex);
    std::vector<double> out;
    for (const auto& [id, at] : started)
      if (auto s = submitted.find(id); s != submitted.end())
        out.push_back(ms_between(s->second, at));
    return out;
  }
};

// A camera's worker with a queue in memory (one camlabd on SQLite).
struct MemoryWorker {
  std::mutex mutex;
  std::condition_variable wake;
  std::deque<int64_t> queue;
  bool stop = false;
};

struct Figures {
  double claimed_per_s = 0, p50_ms = 0, p99_ms = 0;
  int jobs = 0, samples = 0;
};

// Submits `rate` jobs per second for `seconds` (submit(i) for the i-th), waits (bounded)
// for them to start, and fills the latency figures from `timings`.
template <class Submit>
void measure_latency(double rate, double seconds, Submit&& submit, const std::atomic<int>& started,
                     Timings& timings, Figures* figures) {
  const int count = static_cast<int>(rate * seconds);
  const auto begin = Clock::now();
  for (int i = 0; i < count; ++i) {
    std::this_thread::sleep_until(begin +
                                  std::chrono::microseconds(static_cast<int64_t>(i * 1e6 / rate)));
    submit(i);
  }
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  while (started < count && Clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const auto latencies = timings.latencies_ms();
  figures->p50_ms = percentile(latencies, 0.5);
  figures->p99_ms = percentile(latencies, 0.99);
  figures->samples = static_cast<int>(latencies.size());
}

Figures bench_sqlite(int backlog, double rate, double seconds) {
  const fs::path dir =
      fs::temp_directory_path() / ("fleet_claim_bench_" + std::to_string(getpid()));
  fs::create_directories(dir);
  auto store = JobStore::open(dir / "camlabd.sqlite");
  if (!store) {
    std::fprintf(stderr, "sqlite: %s\n", store.error().message.c_str());
    return {};
  }
  Figures figures;
  for (int phase = 0; phase < 2; ++phase) {
    Timings timings;
    std::vector<MemoryWorker> workers(kCamerasPerHost);
    std::atomic<int> started{0};
    std::vector<std::thread> threads;
    for (auto& w : workers)
      threads.emplace_back([&, worker = &w] {
        for (;;) {
          int64_t id;
          {
            std::unique_lock lock(worker->mutex);
            worker->wake.wait(lock, [&] { return worker->stop || !worker->queue.empty(); });
            if (worker->queue.empty()) return;
            id = worker->queue.front();
            worker->queue.pop_front();
          }
          if (*(*store)->start(id)) {
            timings.start(id);
            ++started;
            (void)(*store)->finish(id, JobState::kSucceeded, std::nullopt, {{"frames", 0}});
          }
        }
      });
    auto submit = [&](int i) {
      auto job = (*store)->create("capture", "cam" + std::to_string(i % kCamerasPerHost),
                                  {{"kind", "single"}}, "captures/job-", 1);
      timings.submit(job->id);
      MemoryWorker& w = workers[i % kCamerasPerHost];
      {
        std::lock_guard lock(w.mutex);
        w.queue.push_back(job->id);
      }
      w.wake.notify_one();
    };
    if (phase == 0) {
      // Backlog: queued first (the workers are held at their queues), then drained.
      for (auto& w : workers) w.mutex.lock();
      for (int i = 0; i < backlog; ++i) {
        auto job = (*store)->create("capture", "cam" + std::to_string(i % kCamerasPerHost),
                                    {{"kind", "single"}}, "captures/job-", 1);
        workers[i % kCamerasPerHost].queue.push_back(job->id);
      }
      const auto begin = Clock::now();
      for (auto& w : workers) {
        w.mutex.unlock();
        w.wake.notify_one();
      }
      while (started < backlog) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      figures.claimed_per_s = backlog / (ms_between(begin, Clock::now()) / 1000);
      figures.jobs = backlog;
    } else {
      measure_latency(rate, seconds, submit, started, timings, &figures);
    }
    for (auto& w : workers) {
      {
        std::lock_guard lock(w.mutex);
        w.stop = true;
      }
      w.wake.notify_all();
    }
    for (auto& t : threads) t.join();
  }
  store->reset();
  fs::remove_all(dir);
  return figures;
}

// One PostgreSQL host: its store, a listener thread waking its camera threads, and a
// thread per camera that claims, starts and finishes.
class Host {
 public:
  Host(std::unique_ptr<JobStore> store, Timings* timings, std::atomic<int>* started)
      : store_(std::move(store)), timings_(timings), started_(started) {}
  JobStore& store() { return *store_; }
  FleetStore& fleet() { return *store_->fleet(); }

  void run(bool paused) {
    paused_ = paused;
    listener_ = std::thread([this] {
      auto listener = fleet().listen();
      if (!listener) return;
      while (!stop_) {
        auto notices = (*listener)->wait(std::chrono::milliseconds(500));  // the daemon's poll
        std::lock_guard lock(mutex_);
        ++generation_;
        wake_.notify_all();
        (void)notices;
      }
    });
    for (int c = 0; c < kCamerasPerHost; ++c)
      cameras_.emplace_back([this, c] {
        const std::string camera = "cam" + std::to_string(c);
        uint64_t seen = 0;
        while (!stop_) {
          if (!paused_) {
            auto claimed = fleet().claim(camera, 1);
            if (claimed && !claimed->empty()) {
              for (int64_t id : *claimed)
                if (auto s = store_->start(id); s && *s) {
                  timings_->start(id);
                  ++*started_;
                  (void)store_->finish(id, JobState::kSucceeded, std::nullopt, {{"frames", 0}});
                }
              continue;  // the worker is free again: look for the next at once
            }
          }
          std::unique_lock lock(mutex_);
          wake_.wait_for(lock, std::chrono::milliseconds(500),
                         [&] { return stop_ || generation_ != seen; });
          seen = generation_;
        }
      });
  }
  void resume() {
    paused_ = false;
    std::lock_guard lock(mutex_);
    ++generation_;
    wake_.notify_all();
  }
  void stop() {
    stop_ = true;
    wake_.notify_all();
    if (listener_.joinable()) listener_.join();
    for (auto& t : cameras_) t.join();
    cameras_.clear();
    stop_ = false;
  }

 private:
  std::unique_ptr<JobStore> store_;
  Timings* timings_;
  std::atomic<int>* started_;
  std::atomic<bool> stop_{false}, paused_{false};
  std::mutex mutex_;
  std::condition_variable wake_;
  uint64_t generation_ = 0;
  std::thread listener_;
  std::vector<std::thread> cameras_;
};

Figures bench_postgres(camlab::testing::PgCluster& cluster, int hosts, int backlog, double rate,
                       double seconds, int round) {
  const std::string db = "claims_" + std::to_string(hosts) + "_" + std::to_string(round);
  if (!cluster.create_database(db)) return {};
  Figures figures;
  for (int phase = 0; phase < 2; ++phase) {
    Timings timings;
    std::atomic<int> started{0};
    std::vector<std::unique_ptr<Host>> fleet;
    for (int h = 0; h < hosts; ++h) {
      StoreConfig config;
      config.db = cluster.url(db);
      config.host_name = "host-" + std::to_string(h);
      auto store = open_job_store(config);
      if (!store || !(*store)->fleet()->join("http://bench", std::chrono::seconds(60))) {
        std::fprintf(stderr, "postgres: cannot open host %d\n", h);
        return {};
      }
      fleet.push_back(std::make_unique<Host>(std::move(*store), &timings, &started));
    }
    std::mt19937 rng(round * 7 + hosts);
    auto submit = [&]() {
      Host& via = *fleet[rng() % fleet.size()];
      const std::string target = "host-" + std::to_string(rng() % fleet.size());
      auto job =
          via.fleet().submit(target, "capture", "cam" + std::to_string(rng() % kCamerasPerHost),
                             {{"kind", "single"}}, "captures/job-", 1);
      if (job) timings.submit(job->id);
      return job.ok();
    };
    if (phase == 0) {
      for (auto& host : fleet) host->run(/*paused=*/true);
      for (int i = 0; i < backlog; ++i) submit();
      const auto begin = Clock::now();
      for (auto& host : fleet) host->resume();
      const auto deadline = begin + std::chrono::seconds(120);
      while (started < backlog && Clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      figures.claimed_per_s = started / (ms_between(begin, Clock::now()) / 1000);
      figures.jobs = started;
    } else {
      for (auto& host : fleet) host->run(/*paused=*/false);
      measure_latency(
          rate, seconds, [&](int) { submit(); }, started, timings, &figures);
    }
    for (auto& host : fleet) host->stop();
  }
  return figures;
}

void print(const char* store, int hosts, const Figures& f, double rate) {
  std::printf("| %-10s | %5d | %8d | %11.0f | %8.2f | %8.2f | %7d at %.0f/s |\n", store, hosts,
              f.jobs, f.claimed_per_s, f.p50_ms, f.p99_ms, f.samples, rate);
}

}  // namespace

int main(int argc, char** argv) {
  int backlog = 2000;
  double rate = 50, seconds = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--backlog") backlog = std::atoi(argv[i + 1]);
    if (flag == "--rate") rate = std::atof(argv[i + 1]);
    if (flag == "--seconds") seconds = std::atof(argv[i + 1]);
  }
  std::printf(
      "fleet_claim_bench: %d jobs of backlog; latency at %.0f jobs/s for %.0f s; %d "
      "cameras per host\n\n",
      backlog, rate, seconds, kCamerasPerHost);
  std::printf(
      "| store      | hosts | backlog  | claimed/s   | p50 ms   | p99 ms   | latency samples |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  print("SQLite", 1, bench_sqlite(backlog, rate, seconds), rate);
  if (std::string missing = camlab::testing::PgCluster::missing(); !missing.empty()) {
    std::printf("| PostgreSQL | - | not measured: %s |\n", missing.c_str());
    return 0;
  }
  camlab::testing::PgCluster cluster;
  std::string error;
  // PostgreSQL as it ships: fsync and synchronous commit on, as a fleet would run it.
  if (!cluster.start(&error, /*durable=*/true)) {
    std::printf("| PostgreSQL | - | cluster did not start: %s |\n", error.c_str());
    return 0;
  }
  for (int hosts : {1, 3})
    print("PostgreSQL", hosts, bench_postgres(cluster, hosts, backlog, rate, seconds, hosts), rate);
  return 0;
}
