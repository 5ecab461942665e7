// Job events (service/jobs/job_events.h): what a subscriber receives is the latest change of
// each job, in the order the jobs first changed, with nothing lost but what was replaced by
// a later change of the same job; a subscriber that falls far behind is told to resync; the
// limits and the stop are said.
#include "service/jobs/job_events.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <memory>
#include <thread>

namespace camlab::service {
namespace {

using namespace std::chrono_literals;

Result<JobEventBatch> next_batch(JobEvents::Subscription& s) {
  auto promise = std::make_shared<std::promise<Result<JobEventBatch>>>();
  auto future = promise->get_future();
  s.next([promise](Result<JobEventBatch> batch) { promise->set_value(std::move(batch)); });
  if (future.wait_for(5s) != std::future_status::ready)
    return make_error("timeout", "no batch within the test's bound");
  return future.get();
}

TEST(JobEvents, ABatchHoldsEachJobsLatestChangeInTheOrderJobsFirstChanged) {
  JobEvents events;
  events.start();
  auto sub = events.subscribe();
  ASSERT_TRUE(sub.ok());
  events.publish({1, JobState::kQueued, 0, 10, 0});
  events.publish({2, JobState::kQueued, 0, 5, 0});
  events.publish({1, JobState::kRunning, 3, 10, 1});
  events.publish({1, JobState::kRunning, 7, 10, 1});
  auto batch = next_batch(**sub);
  ASSERT_TRUE(batch.ok()) << batch.error().message;
  EXPECT_FALSE(batch->resync);
  ASSERT_EQ(batch->changes.size(), 2u);
  EXPECT_EQ(batch->changes[0].id, 1);
  EXPECT_EQ(batch->changes[0].state, JobState::kRunning);
  EXPECT_EQ(batch->changes[0].frames_done, 7);
  EXPECT_EQ(batch->changes[1].id, 2);
  EXPECT_EQ(batch->changes[1].state, JobState::kQueued);

  // What comes later comes in the next batch, final states included.
  events.publish({1, JobState::kSucceeded, 10, 10, 1});
  auto later = next_batch(**sub);
  ASSERT_TRUE(later.ok());
  ASSERT_EQ(later->changes.size(), 1u);
  EXPECT_EQ(later->changes[0].state, JobState::kSucceeded);
}

TEST(JobEvents, ASubscriberFarBehindIsToldToResync) {
  JobEvents events;
  events.start();
  auto sub = events.subscribe();
  ASSERT_TRUE(sub.ok());
  for (int64_t id = 1; id <= static_cast<int64_t>(JobEvents::kMaxPendingJobs) + 1; ++id)
    events.publish({id, JobState::kQueued});
  auto batch = next_batch(**sub);
  ASSERT_TRUE(batch.ok());
  EXPECT_TRUE(batch->resync);
  EXPECT_TRUE(batch->changes.empty());
  // Back in step afterwards.
  events.publish({5000, JobState::kQueued});
  auto next = next_batch(**sub);
  ASSERT_TRUE(next.ok());
  EXPECT_FALSE(next->resync);
  ASSERT_EQ(next->changes.size(), 1u);
}

TEST(JobEvents, LimitsAndTheStopAreSaid) {
  JobEvents events;
  events.start();
  std::vector<std::shared_ptr<JobEvents::Subscription>> subs;
  for (int i = 0; i < JobEvents::kMaxSubscribers; ++i) {
    auto s = events.subscribe();
    ASSERT_TRUE(s.ok());
    subs.push_back(*s);
  }
  EXPECT_EQ(events.subscribe().error().code, ErrorCode::kTooManyConnections);
  subs.pop_back();  // leaving frees a place
  EXPECT_TRUE(events.subscribe().ok());

  auto promise = std::make_shared<std::promise<ErrorCode>>();
  subs[0]->next([promise](Result<JobEventBatch> batch) {
    promise->set_value(batch ? ErrorCode::kInternal : batch.error().code);
  });
  events.stop();
  auto future = promise->get_future();
  ASSERT_EQ(future.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(future.get(), ErrorCode::kShuttingDown);
  EXPECT_EQ(events.subscribe().error().code, ErrorCode::kShuttingDown);
}

// What an HTTP session is to its event stream: the owner whose destruction closes the
// subscription. A callback may hold the last reference to it; dropping that callback must
// not happen under the hub's lock, or close() waits on the lock its own thread holds (a
// camlabd that never stopped: ServiceLive.EventsShowAJobFromItsStartToItsEndInOrder, once
// in about 15 runs under load).
struct ClosesWhenDropped {
  std::shared_ptr<JobEvents::Subscription> subscription;
  std::shared_ptr<std::promise<void>> closed = std::make_shared<std::promise<void>>();
  ~ClosesWhenDropped() {
    subscription->close();
    closed->set_value();
  }
};

// Waits (bounded) for the owner's close() to return. A hub deadlocked on itself cannot be
// cleaned up (its destructor would join the stuck thread), so the test process ends here.
void expect_closed_within_bound(std::future<void> closed, const char* what) {
  if (closed.wait_for(5s) == std::future_status::ready) return;
  std::fprintf(stderr, "FAILED: %s: close() did not return within 5 s (deadlocked)\n", what);
  std::_Exit(1);
}

TEST(JobEvents, ACallbackHoldingTheLastReferenceToItsStreamMayCloseItWhenDropped) {
  JobEvents events;
  events.start();
  {
    // Dropped by the event thread after it delivered.
    auto sub = events.subscribe();
    ASSERT_TRUE(sub.ok());
    auto owner = std::make_shared<ClosesWhenDropped>();
    owner->subscription = *sub;
    auto closed = owner->closed->get_future();
    auto delivered = std::make_shared<std::promise<void>>();
    (*sub)->next([owner, delivered](Result<JobEventBatch>) { delivered->set_value(); });
    owner.reset();
    events.publish({1, JobState::kQueued, 0, 1, 0});
    ASSERT_EQ(delivered->get_future().wait_for(5s), std::future_status::ready);
    expect_closed_within_bound(std::move(closed), "dropped after delivery");
  }
  {
    // Dropped by close() from elsewhere (the client left) while the callback waits.
    auto sub = events.subscribe();
    ASSERT_TRUE(sub.ok());
    auto owner = std::make_shared<ClosesWhenDropped>();
    owner->subscription = *sub;
    auto closed = owner->closed->get_future();
    (*sub)->next([owner](Result<JobEventBatch>) {});
    owner.reset();
    std::thread([s = *sub] { s->close(); }).detach();
    expect_closed_within_bound(std::move(closed), "dropped by close()");
  }
  // The hub still serves.
  auto sub = events.subscribe();
  ASSERT_TRUE(sub.ok());
  events.publish({2, JobState::kQueued, 0, 1, 0});
  auto batch = next_batch(**sub);
  ASSERT_TRUE(batch.ok()) << batch.error().message;
  ASSERT_EQ(batch->changes.size(), 1u);
  EXPECT_EQ(batch->changes[0].id, 2);
}

}  // namespace
}  // namespace camlab::service
