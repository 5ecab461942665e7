// The fleet's operations on PostgreSQL (service/store/fleet_store.h), each test in a
// throwaway cluster of its own (tests/support/pg_cluster.h; skipped, saying why, when the
// server binaries are not installed): claims never hand a job out twice, a passed lease ends
// its host's jobs exactly once however many hosts sweep, a write waits out a database
// restart and is stored once, and a fenced host makes no job step.
#include "service/store/fleet_store.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "service/store/job_store.h"
#include "service/store/open_job_store.h"
#include "tests/support/job_history.h"
#include "tests/support/pg_cluster.h"

namespace camlab::service {
namespace {

using namespace std::chrono_literals;
using testing::job_histories;

class FleetStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string missing = testing::PgCluster::missing(); !missing.empty())
      GTEST_SKIP() << missing;
    std::string error;
    ASSERT_TRUE(cluster_.start(&error)) << error;
    ASSERT_TRUE(cluster_.create_database("fleet"));
  }

  // A host's store (its own connections), joined unless said otherwise.
  std::unique_ptr<JobStore> host(const std::string& name, std::chrono::milliseconds lease = 60s,
                                 bool join = true, std::chrono::milliseconds patience = 20s,
                                 const std::string& identity = "") {
    StoreConfig config;
    config.db = cluster_.url("fleet");
    config.host_name = name;
    config.host_identity = identity;
    config.retry.worker_patience = patience;
    auto store = open_job_store(config);
    EXPECT_TRUE(store.ok()) << store.error().message;
    if (!store) return nullptr;
    EXPECT_NE((*store)->fleet(), nullptr);
    if (join) {
      Status joined = (*store)->fleet()->join("http://" + name, lease);
      EXPECT_TRUE(joined.ok()) << joined.error().message;
    }
    return std::move(*store);
  }

  // Each job's states in the order its history (job_events) holds them.
  std::map<int64_t, std::vector<std::string>> history() {
    bool ok = false;
    auto states = job_histories(cluster_, "fleet", &ok);
    EXPECT_TRUE(ok);
    return states;
  }

  testing::PgCluster cluster_;
};

TEST_F(FleetStoreTest, ConcurrentClaimersTakeEveryJobExactlyOnce) {
  auto submitter = host("submitter");
  // Two connections of one host claiming together: SKIP LOCKED passes over the rows the
  // other is taking, never hands one out twice.
  auto first = host("cam-host");
  auto second = host("cam-host", 60s, /*join=*/false);
  constexpr int kJobs = 300;
  std::set<int64_t> submitted;
  for (int i = 0; i < kJobs; ++i) {
    auto job =
        submitter->fleet()->submit("cam-host", "capture", "cam0", {{"i", i}}, "captures/job-", 1);
    ASSERT_TRUE(job.ok()) << job.error().message;
    EXPECT_EQ(job->host, "cam-host");
    EXPECT_EQ(job->folder, job_folder_name("captures/job-", job->id));
    submitted.insert(job->id);
  }
  // Another host's claims for a camera of the same name take nothing.
  EXPECT_TRUE(submitter->fleet()->claim("cam0", 10)->empty());
  EXPECT_EQ(*first->fleet()->waiting("cam-host", "cam0"), kJobs);

  std::vector<int64_t> taken[2];
  std::thread claimers[2];
  JobStore* stores[2] = {first.get(), second.get()};
  for (int c = 0; c < 2; ++c)
    claimers[c] = std::thread([&, c] {
      for (int rounds = 0; rounds < 10 * kJobs; ++rounds) {
        auto claimed = stores[c]->fleet()->claim("cam0", 3);
        ASSERT_TRUE(claimed.ok()) << claimed.error().message;
        if (claimed->empty()) return;
        for (int64_t id : *claimed) {
          taken[c].push_back(id);
          // Claimed by this host: it may start it, once.
          EXPECT_TRUE(*stores[c]->start(id));
        }
      }
    });
  for (auto& t : claimers) t.join();
  std::multiset<int64_t> all(taken[0].begin(), taken[0].end());
  all.insert(taken[1].begin(), taken[1].end());
  EXPECT_EQ(all.size(), submitted.size());
  EXPECT_EQ(std::set<int64_t>(all.begin(), all.end()), submitted);
  EXPECT_EQ(*first->fleet()->waiting("cam-host", "cam0"), 0);
  EXPECT_EQ(first->count_by_state()->at("running"), kJobs);
}

TEST_F(FleetStoreTest, APassedLeaseEndsItsHostsJobsExactlyOnceWhoeverSweeps) {
  auto dying = host("dying", 400ms);
  auto sweeper_a = host("sweeper-a");
  auto sweeper_b = host("sweeper-b");
  // Running, claimed and waiting, and one of another host's that must stay.
  const int64_t running = dying->create("capture", "cam0", {{"n", 1}}, "captures/job-", 5)->id;
  ASSERT_TRUE(*dying->start(running));
  const int64_t claimed = dying->create("capture", "cam0", {{"n", 2}}, "captures/job-", 5)->id;
  const int64_t waiting =
      sweeper_a->fleet()->submit("dying", "capture", "cam1", {{"n", 3}}, "captures/job-", 5)->id;
  const int64_t elsewhere =
      sweeper_a->create("capture", "cam0", {{"n", 4}}, "captures/job-", 5)->id;

  std::this_thread::sleep_for(600ms);  // the lease (400 ms) passes unrenewed
  std::vector<ExpiredHost> swept[2];
  std::thread sweepers[2];
  JobStore* stores[2] = {sweeper_a.get(), sweeper_b.get()};
  for (int s = 0; s < 2; ++s)
    sweepers[s] = std::thread([&, s] {
      for (int round = 0; round < 5; ++round) {
        auto expired = stores[s]->fleet()->expire_hosts();
        ASSERT_TRUE(expired.ok()) << expired.error().message;
        swept[s].insert(swept[s].end(), expired->begin(), expired->end());
      }
    });
  for (auto& t : sweepers) t.join();
  std::multiset<int64_t> interrupted;
  int expirations = 0;
  for (const auto& list : swept)
    for (const ExpiredHost& host : list) {
      EXPECT_EQ(host.name, "dying");
      expirations += host.jobs_interrupted.empty() ? 0 : 1;
      interrupted.insert(host.jobs_interrupted.begin(), host.jobs_interrupted.end());
    }
  EXPECT_EQ(interrupted, (std::multiset<int64_t>{running, claimed, waiting}));
  EXPECT_EQ(expirations, 1);
  for (int64_t id : {running, claimed, waiting}) {
    const JobRecord job = **sweeper_b->get(id);
    EXPECT_EQ(job.state, JobState::kInterrupted) << id;
    EXPECT_NE(job.error_message.find("lease"), std::string::npos) << job.error_message;
  }
  EXPECT_EQ((*sweeper_b->get(elsewhere))->state, JobState::kQueued);
  const auto states = history();
  for (int64_t id : {running, claimed, waiting})
    EXPECT_EQ(std::count(states.at(id).begin(), states.at(id).end(), "interrupted"), 1) << id;

  // The host that was away: its lease is not renewed, its late finish is refused, and
  // its jobs stay as the fleet ended them.
  auto renewal = dying->fleet()->renew();
  ASSERT_TRUE(renewal.ok());
  EXPECT_FALSE(renewal->renewed);
  EXPECT_FALSE(*dying->finish(running, JobState::kSucceeded, std::nullopt, {{"late", true}}));
  EXPECT_EQ((*sweeper_a->get(running))->state, JobState::kInterrupted);
  // Joined again, it takes work again.
  ASSERT_TRUE(dying->fleet()->join("http://dying", 60s).ok());
  EXPECT_TRUE(sweeper_a->fleet()->submit("dying", "capture", "cam1", {{"n", 5}}, "", 1).ok());
}

TEST_F(FleetStoreTest, OnlyALiveHostIsGivenJobsAndLeavingEndsItsOwn) {
  auto submitter = host("submitter");
  auto absent = submitter->fleet()->submit("nobody", "capture", "cam0", {{"n", 1}}, "", 1);
  ASSERT_FALSE(absent.ok());
  EXPECT_EQ(absent.error().code, ErrorCode::kHostUnavailable);
  EXPECT_NE(absent.error().message.find("nobody"), std::string::npos);

  auto leaving = host("leaving");
  const int64_t waiting =
      submitter->fleet()->submit("leaving", "capture", "cam0", {{"n", 2}}, "", 1)->id;
  const int64_t running = leaving->create("analysis", "", {{"n", 3}}, "", 0)->id;
  ASSERT_TRUE(*leaving->start(running));
  ASSERT_TRUE(leaving->fleet()->leave("camlabd stopped").ok());
  for (int64_t id : {waiting, running}) {
    const JobRecord job = **submitter->get(id);
    EXPECT_EQ(job.state, JobState::kInterrupted);
    EXPECT_EQ(job.error_message, "camlabd stopped");
  }
  auto refused = submitter->fleet()->submit("leaving", "capture", "cam0", {{"n", 4}}, "", 1);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kHostUnavailable);
  auto hosts = submitter->fleet()->hosts();
  ASSERT_TRUE(hosts.ok());
  std::map<std::string, std::string> states;
  for (const FleetHost& h : *hosts) states[h.name] = h.state;
  EXPECT_EQ(states,
            (std::map<std::string, std::string>{{"leaving", "left"}, {"submitter", "live"}}));
}

TEST_F(FleetStoreTest, NotificationsTellTheHostOfItsJobsAndWhoseStoreSentThem) {
  auto cam_host = host("cam-host");
  auto other = host("other");
  auto listener = cam_host->fleet()->listen();
  ASSERT_TRUE(listener.ok());
  ASSERT_TRUE((*listener)->wait(50ms).ok());  // connected and listening from here on
  const int64_t id = other->fleet()->submit("cam-host", "capture", "cam0", {{"n", 1}}, "", 2)->id;
  ASSERT_EQ(*cam_host->fleet()->claim("cam0", 1), std::vector<int64_t>{id});
  ASSERT_TRUE(*cam_host->start(id));
  std::vector<FleetNotice> seen;
  for (int i = 0; i < 50 && seen.size() < 2; ++i) {
    auto notices = (*listener)->wait(100ms);
    ASSERT_TRUE(notices.ok()) << notices.error().message;
    for (const FleetNotice& n : *notices)
      if (n.channel == "camlab_jobs" && n.payload.value("id", int64_t{0}) == id) seen.push_back(n);
  }
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].payload["state"], "queued");
  EXPECT_EQ(seen[0].payload["host"], "cam-host");
  EXPECT_EQ(seen[0].payload["camera_id"], "cam0");
  EXPECT_FALSE(seen[0].from_own_store);  // another host's submission
  EXPECT_EQ(seen[1].payload["state"], "running");
  EXPECT_TRUE(seen[1].from_own_store);  // its own job store's start
  // A cancel request is notified to the host running the job, and listed for it.
  ASSERT_TRUE(*other->fleet()->request_cancel(id));
  EXPECT_EQ(*cam_host->fleet()->cancel_requests(),
            (std::vector<std::pair<int64_t, std::string>>{{id, "cam0"}}));
  bool cancel_seen = false;
  for (int i = 0; i < 50 && !cancel_seen; ++i) {
    auto notices = (*listener)->wait(100ms);
    ASSERT_TRUE(notices.ok()) << notices.error().message;
    for (const FleetNotice& n : *notices)
      cancel_seen = cancel_seen ||
                    (n.payload.value("id", int64_t{0}) == id && n.payload.value("cancel", false));
  }
  EXPECT_TRUE(cancel_seen);
  ASSERT_TRUE(*cam_host->finish(id, JobState::kCancelled, make_error("cancelled", "asked"), {}));
  EXPECT_FALSE(*other->fleet()->request_cancel(id));  // no longer running
}

TEST_F(FleetStoreTest, AWorkersWriteWaitsOutADatabaseRestartAndIsStoredOnce) {
  auto store = host("cam-host");
  const int64_t id = store->create("capture", "cam0", {{"n", 1}}, "captures/job-", 10)->id;
  ASSERT_TRUE(*store->start(id));
  ASSERT_TRUE(store->progress(id, 3, 10, 0).ok());
  ASSERT_TRUE(cluster_.stop());
  // Down: a read fails at once with a clear error; the worker's finish waits.
  auto read = store->get(id);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kDatabaseUnavailable);
  EXPECT_NE(read.error().message.find("127.0.0.1"), std::string::npos) << read.error().message;
  std::thread restarter([&] {
    std::this_thread::sleep_for(1500ms);
    EXPECT_TRUE(cluster_.resume());
  });
  ASSERT_TRUE(store->progress(id, 7, 10, 1).ok() || true);  // memory keeps it either way
  auto finished = store->finish(id, JobState::kSucceeded, std::nullopt, {{"frames", 10}});
  restarter.join();
  ASSERT_TRUE(finished.ok()) << finished.error().message;
  EXPECT_TRUE(*finished);
  auto other = host("reader", 60s, false);
  const JobRecord job = **other->get(id);
  EXPECT_EQ(job.state, JobState::kSucceeded);
  EXPECT_EQ(job.frames_done, 7);
  EXPECT_EQ(job.frames_discarded, 1);
  EXPECT_EQ(job.result, nlohmann::json({{"frames", 10}}));
  EXPECT_EQ(history().at(id), (std::vector<std::string>{"queued", "running", "succeeded"}));
}

TEST_F(FleetStoreTest, AFencedHostMakesNoJobStepUntilUnfenced) {
  // A worker's write waits out a fence no longer than its patience (here short).
  auto store = host("cam-host", 60s, true, 200ms);
  const int64_t id = store->create("capture", "cam0", {{"n", 1}}, "", 2)->id;
  store->fleet()->set_fenced(true);
  EXPECT_TRUE(store->fleet()->fenced());
  auto started = store->start(id);
  ASSERT_FALSE(started.ok());
  EXPECT_EQ(started.error().code, ErrorCode::kDatabaseUnavailable);
  EXPECT_NE(started.error().message.find("lease"), std::string::npos) << started.error().message;
  auto finished = store->finish(id, JobState::kFailed, std::nullopt, nullptr);
  ASSERT_FALSE(finished.ok());
  EXPECT_EQ(finished.error().code, ErrorCode::kDatabaseUnavailable);
  EXPECT_EQ((*store->get(id))->state, JobState::kQueued);  // reads still work
  store->fleet()->set_fenced(false);
  EXPECT_TRUE(*store->start(id));
  // Interrupting what it had taken is how a host rejoins: allowed.
  EXPECT_EQ(*store->interrupt_unfinished("lost its lease"), 1);
  EXPECT_EQ((*store->get(id))->state, JobState::kInterrupted);
}

TEST_F(FleetStoreTest, RecoveryListsWhatTheFleetInterruptedWhileTheHostWasAway) {
  auto away = host("away", 300ms);
  auto sweeper = host("sweeper");
  const int64_t running = away->create("capture", "cam0", {{"n", 1}}, "captures/job-", 9)->id;
  ASSERT_TRUE(*away->start(running));
  ASSERT_TRUE(away->progress(running, 2, 9, 0).ok());
  const int64_t done = away->create("capture", "cam0", {{"n", 2}}, "captures/job-", 1)->id;
  ASSERT_TRUE(*away->finish(done, JobState::kSucceeded, std::nullopt, nullptr));
  std::this_thread::sleep_for(500ms);
  ASSERT_EQ(sweeper->fleet()->expire_hosts()->size(), 1u);
  // The host comes back (a new process): the interrupted capture is to be recovered, the
  // finished one is not.
  auto back = host("away", 60s, /*join=*/false);
  auto jobs = back->fleet()->jobs_to_recover();
  ASSERT_TRUE(jobs.ok());
  ASSERT_EQ(jobs->size(), 1u);
  EXPECT_EQ((*jobs)[0].id, running);
  EXPECT_EQ((*jobs)[0].state, JobState::kInterrupted);
  ASSERT_TRUE(back->fleet()->set_recovered_frames(running, 5).ok());
  EXPECT_EQ((*back->get(running))->frames_done, 5);
  ASSERT_TRUE(back->fleet()->set_recovered_frames(running, 4).ok());  // never lowered
  EXPECT_EQ((*back->get(running))->frames_done, 5);
}

// Cloned hosts (one --host-name, two machines): the name is held by one identity while its
// host is live; another is refused without touching it, the same identity (a restart) takes
// it at once, and anyone takes it once the holder's lease has passed.
TEST_F(FleetStoreTest, ANameIsHeldByOneIdentityWhileItsHostIsLive) {
  auto first = host("lab", 400ms, /*join=*/true, 20s, "aaaa@boot1");
  ASSERT_NE(first, nullptr);
  auto clone = host("lab", 60s, /*join=*/false, 20s, "bbbb@boot2");
  ASSERT_NE(clone, nullptr);
  const Status refused = clone->fleet()->hold_name(60s);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, "exists");
  EXPECT_NE(refused.error().message.find("http://lab"), std::string::npos)
      << refused.error().message;
  EXPECT_FALSE(clone->fleet()->join("http://clone", 60s).ok());
  EXPECT_TRUE(first->fleet()->renew()->renewed);  // the holder was not disturbed
  auto restarted = host("lab", 400ms, /*join=*/false, 20s, "aaaa@boot1");
  EXPECT_TRUE(restarted->fleet()->hold_name(400ms).ok());
  std::this_thread::sleep_for(600ms);  // the holder's lease passes
  EXPECT_TRUE(clone->fleet()->hold_name(60s).ok());
}

// A finished job another host cached is read anew once the fleet says it changed: a
// restarted host recovered its frames (5), and the other host's cache said 2.
TEST_F(FleetStoreTest, AFinishedJobCachedByAnotherHostIsReadAnewWhenTheFleetSaysItChanged) {
  auto away = host("away", 300ms);
  auto other = host("other");
  const int64_t id = away->create("capture", "cam0", {{"n", 1}}, "captures/job-", 9)->id;
  ASSERT_TRUE(*away->start(id));
  ASSERT_TRUE(away->progress(id, 2, 9, 0).ok());
  std::this_thread::sleep_for(500ms);
  ASSERT_EQ(other->fleet()->expire_hosts()->size(), 1u);
  EXPECT_EQ((*other->get(id))->frames_done, 2);  // finished (interrupted): cached here
  auto back = host("away", 60s, /*join=*/false);
  ASSERT_TRUE(back->fleet()->set_recovered_frames(id, 5).ok());
  other->relay_change({id, JobState::kInterrupted, 5, 9, 0});  // what the notification says
  EXPECT_EQ((*other->get(id))->frames_done, 5);
}

}  // namespace
}  // namespace camlab::service
