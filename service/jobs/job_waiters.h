// Long-polls on jobs: GET /v1/jobs/{id}?wait=S answers once the job has finished, or
// after S seconds, whichever comes first (so a script, or the README's session typed line
// by line, needs no polling loop). Waiting requests hold no I/O thread: they are kept here
// and one thread looks at their jobs every 50 ms.
//
// Bounded: at most `max_waiting` requests wait at once; beyond that wait() refuses and the
// handler answers at once with the job as it is (the client polls again; never an error).
//
// Thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace camlab::service {

class JobStore;
struct JobRecord;

class JobWaiters {
 public:
  using Answer = std::function<void(const JobRecord* job)>;  // null: the job is gone

  explicit JobWaiters(JobStore& store, int max_waiting = 256);
  ~JobWaiters();
  JobWaiters(const JobWaiters&) = delete;
  JobWaiters& operator=(const JobWaiters&) = delete;

  void start();
  void stop();  // answers every waiting request with its job as it is now

  // Calls `answer` once, from the waiters' thread, when job `id` has finished or at
  // `deadline`. False (and `answer` is not called) when full or stopped.
  bool wait(int64_t id, std::chrono::steady_clock::time_point deadline, Answer answer);

 private:
  struct Waiting {
    int64_t id;
    std::chrono::steady_clock::time_point deadline;
    Answer answer;
  };
  void run();
  void answer_all(std::vector<Waiting> waiting, bool only_due);

  JobStore& store_;
  const size_t max_waiting_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<Waiting> waiting_;
  bool started_ = false, stopping_ = false;
  std::thread thread_;
};

}  // namespace camlab::service
