// Long-polls (service/jobs/job_waiters.h) on the real SQLite job store: waiting requests
// are answered when their job finishes, told by the store's change observer, or at their
// deadline; the store is read once when a request starts waiting and once when it is
// answered, never on a timer (250 waiters read the store 5,000 times a second before);
// the cap refuses the request past it.
#include "service/jobs/job_waiters.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "service/store/job_store.h"
#include "service/store/sqlite_job_store.h"

namespace camlab::service {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

class JobWaitersTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("camlab_job_waiters_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    auto opened = SqliteJobStore::open(dir_ / "jobs.sqlite");
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    store_ = std::move(*opened);
    store_->set_change_observer([this](const JobChange& c) {
      if (waiters_) waiters_->notify(c);
    });
  }
  void TearDown() override {
    waiters_.reset();
    store_.reset();
    fs::remove_all(dir_);
  }
  int64_t running_job() {
    auto job = store_->create("calibration", "", nlohmann::json::object(), "", 0);
    EXPECT_TRUE(job.ok());
    EXPECT_TRUE(store_->start(job->id).ok());
    return job->id;
  }
  fs::path dir_;
  std::unique_ptr<JobStore> store_;
  std::unique_ptr<JobWaiters> waiters_;
};

TEST_F(JobWaitersTest, FinishingTheJobAnswersEveryWaiterWithTwoStoreReadsEach) {
  waiters_ = std::make_unique<JobWaiters>(*store_, 300);
  waiters_->start();
  const int64_t id = running_job();
  constexpr int kWaiters = 250;
  std::atomic<int> answered{0}, finished{0};
  for (int i = 0; i < kWaiters; ++i)
    ASSERT_TRUE(
        waiters_->wait(id, std::chrono::steady_clock::now() + 30s, [&](const JobRecord* job) {
          ++answered;
          if (job && is_finished(job->state)) ++finished;
        }));
  // A second of waiting: nobody is answered, and the store was read once per waiter.
  std::this_thread::sleep_for(1s);
  EXPECT_EQ(answered.load(), 0);
  EXPECT_EQ(waiters_->store_reads(), kWaiters);
  ASSERT_TRUE(
      store_->finish(id, JobState::kSucceeded, std::nullopt, nlohmann::json::object()).ok());
  for (int i = 0; i < 500 && answered.load() < kWaiters; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(answered.load(), kWaiters);
  EXPECT_EQ(finished.load(), kWaiters);
  EXPECT_EQ(waiters_->store_reads(), 2 * kWaiters);
}

TEST_F(JobWaitersTest, AJobThatFinishedBeforeTheWaitIsAnsweredAtOnce) {
  waiters_ = std::make_unique<JobWaiters>(*store_, 4);
  waiters_->start();
  const int64_t id = running_job();
  ASSERT_TRUE(store_->finish(id, JobState::kFailed, std::nullopt, nlohmann::json::object()).ok());
  std::atomic<bool> answered{false};
  ASSERT_TRUE(waiters_->wait(id, std::chrono::steady_clock::now() + 30s,
                             [&](const JobRecord*) { answered = true; }));
  for (int i = 0; i < 500 && !answered; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_TRUE(answered);
}

TEST_F(JobWaitersTest, TheDeadlineAnswersAndTheCapRefuses) {
  waiters_ = std::make_unique<JobWaiters>(*store_, 2);
  waiters_->start();
  const int64_t id = running_job();
  std::atomic<int> answered{0};
  const auto deadline = std::chrono::steady_clock::now() + 300ms;
  auto count = [&](const JobRecord* job) {
    EXPECT_NE(job, nullptr);
    ++answered;
  };
  EXPECT_TRUE(waiters_->wait(id, deadline, count));
  EXPECT_TRUE(waiters_->wait(id, deadline, count));
  EXPECT_FALSE(waiters_->has_room());
  EXPECT_FALSE(waiters_->wait(id, deadline, count));  // past the cap: the caller answers
  for (int i = 0; i < 500 && answered.load() < 2; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(answered.load(), 2);
  EXPECT_GE(std::chrono::steady_clock::now(), deadline);
  // Two reads each: when they started waiting, and at the deadline.
  EXPECT_EQ(waiters_->store_reads(), 4);
}

}  // namespace
}  // namespace camlab::service
