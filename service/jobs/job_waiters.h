// Long-polls on jobs: GET /v1/jobs/{id}?wait=S answers once the job has finished, or
// after S seconds, whichever comes first (so a script, or the README's session typed line
// by line, needs no polling loop). Waiting requests hold no I/O thread: they are kept here,
// and one thread answers them when the job store says their job finished (notify(), from
// the store's change observer, which on a fleet host also sees other hosts' changes) or at
// their deadline. The store is read once when a request starts waiting (its job may have
// finished meanwhile) and once when it is answered, never on a timer: 250 waiting requests
// cost what 250 single reads do (the store was read for every waiter every 50 ms, 1,258 to
// 1,455 PostgreSQL transactions a second for 250 waiters).
//
// Bounded: at most `max_waiting` requests wait at once, well below the connection limit
// (a quarter of it in camlabd) so that waiting requests cannot hold every connection;
// beyond that the handler answers 503 with Retry-After before reading the store.
//
// Thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

namespace camlab::service {

class JobStore;
struct JobRecord;
struct JobChange;

class JobWaiters {
 public:
  using Answer = std::function<void(const JobRecord* job)>;  // null: the job is gone

  explicit JobWaiters(JobStore& store, int max_waiting = 64);
  ~JobWaiters();
  JobWaiters(const JobWaiters&) = delete;
  JobWaiters& operator=(const JobWaiters&) = delete;

  void start();
  void stop();  // answers every waiting request with its job as it is now

  // Whether wait() would take one more request now, and how many it takes in all.
  bool has_room() const;
  size_t capacity() const { return max_waiting_; }

  // Calls `answer` once, from the waiters' thread, when job `id` has finished or at
  // `deadline`. False (and `answer` is not called) when full or stopped.
  bool wait(int64_t id, std::chrono::steady_clock::time_point deadline, Answer answer);

  // A job changed (the store's change observer, called under the store's lock): records
  // a finished job and wakes the thread; never reads the store.
  void notify(const JobChange& change);

  // Store reads made for waiting requests so far (for tests and metrics).
  int64_t store_reads() const;

 private:
  struct Waiting {
    int64_t id;
    std::chrono::steady_clock::time_point deadline;
    Answer answer;
    bool checked = false;  // its job was read once since it started waiting
  };
  void run();
  // Answers each of `due` whose job has finished, is gone or whose deadline has passed
  // (all of them when `all`); the rest wait on.
  void answer_due(std::vector<Waiting> due, bool all);

  JobStore& store_;
  const size_t max_waiting_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<Waiting> waiting_;
  std::set<int64_t> finished_;  // jobs notified finished since the thread last looked
  bool unchecked_ = false;      // a request started waiting since the thread last looked
  int64_t store_reads_ = 0;
  bool started_ = false, stopping_ = false;
  std::thread thread_;
};

}  // namespace camlab::service
