#include "service/jobs/job_waiters.h"

#include "service/store/job_store.h"

namespace camlab::service {

JobWaiters::JobWaiters(JobStore& store, int max_waiting)
    : store_(store), max_waiting_(static_cast<size_t>(max_waiting)) {}

JobWaiters::~JobWaiters() { stop(); }

void JobWaiters::start() {
  std::lock_guard lock(mutex_);
  if (started_) return;
  started_ = true;
  thread_ = std::thread([this] { run(); });
}

void JobWaiters::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::vector<Waiting> left;
  {
    std::lock_guard lock(mutex_);
    left.swap(waiting_);
  }
  answer_all(std::move(left), false);
}

bool JobWaiters::wait(int64_t id, std::chrono::steady_clock::time_point deadline, Answer answer) {
  std::lock_guard lock(mutex_);
  if (!started_ || stopping_ || waiting_.size() >= max_waiting_) return false;
  waiting_.push_back({id, deadline, std::move(answer)});
  return true;
}

// Answers each of `waiting` whose job has finished (or, unless only_due, all of them);
// the rest go back to the list. Store reads happen without the list's lock.
void JobWaiters::answer_all(std::vector<Waiting> waiting, bool only_due) {
  const auto now = std::chrono::steady_clock::now();
  std::vector<Waiting> keep;
  for (auto& w : waiting) {
    auto job = store_.get(w.id);
    const JobRecord* record = job && job->has_value() ? &**job : nullptr;
    const bool due =
        !only_due || record == nullptr || is_finished(record->state) || now >= w.deadline;
    if (due)
      w.answer(record);
    else
      keep.push_back(std::move(w));
  }
  if (keep.empty()) return;
  std::lock_guard lock(mutex_);
  for (auto& w : keep) waiting_.push_back(std::move(w));
}

void JobWaiters::run() {
  for (;;) {
    std::vector<Waiting> waiting;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(50), [this] { return stopping_; });
      if (stopping_) return;
      waiting.swap(waiting_);
    }
    answer_all(std::move(waiting), true);
  }
}

}  // namespace camlab::service
