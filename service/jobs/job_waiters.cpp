#include "service/jobs/job_waiters.h"

#include <algorithm>

#include "service/store/job_store.h"

namespace camlab::service {

JobWaiters::JobWaiters(JobStore& store, int max_waiting)
    : store_(store), max_waiting_(static_cast<size_t>(std::max(1, max_waiting))) {}

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
  answer_due(std::move(left), true);
}

bool JobWaiters::has_room() const {
  std::lock_guard lock(mutex_);
  return started_ && !stopping_ && waiting_.size() < max_waiting_;
}

bool JobWaiters::wait(int64_t id, std::chrono::steady_clock::time_point deadline, Answer answer) {
  {
    std::lock_guard lock(mutex_);
    if (!started_ || stopping_ || waiting_.size() >= max_waiting_) return false;
    waiting_.push_back({id, deadline, std::move(answer)});
    unchecked_ = true;
  }
  wake_.notify_all();
  return true;
}

void JobWaiters::notify(const JobChange& change) {
  if (!is_finished(change.state)) return;
  {
    // Recorded even when no request waits for it now: one may be out of the list, being
    // read by the thread, and must not miss the news.
    std::lock_guard lock(mutex_);
    if (!started_ || stopping_) return;
    finished_.insert(change.id);
  }
  wake_.notify_all();
}

int64_t JobWaiters::store_reads() const {
  std::lock_guard lock(mutex_);
  return store_reads_;
}

void JobWaiters::answer_due(std::vector<Waiting> due, bool all) {
  const auto now = std::chrono::steady_clock::now();
  std::vector<Waiting> keep;
  for (auto& w : due) {
    auto job = store_.get(w.id);
    {
      std::lock_guard lock(mutex_);
      ++store_reads_;
    }
    const JobRecord* record = job && job->has_value() ? &**job : nullptr;
    if (all || record == nullptr || is_finished(record->state) || now >= w.deadline) {
      w.answer(record);
    } else {
      w.checked = true;
      keep.push_back(std::move(w));
    }
  }
  if (keep.empty()) return;
  std::lock_guard lock(mutex_);
  for (auto& w : keep) waiting_.push_back(std::move(w));
}

void JobWaiters::run() {
  for (;;) {
    std::vector<Waiting> due;
    {
      std::unique_lock lock(mutex_);
      auto something_due = [this] {
        if (stopping_ || unchecked_ || !finished_.empty()) return true;
        const auto now = std::chrono::steady_clock::now();
        return std::any_of(waiting_.begin(), waiting_.end(),
                           [&](const Waiting& w) { return now >= w.deadline; });
      };
      while (!something_due()) {
        if (waiting_.empty()) {
          wake_.wait(lock);
        } else {
          auto earliest = waiting_.front().deadline;
          for (const auto& w : waiting_) earliest = std::min(earliest, w.deadline);
          wake_.wait_until(lock, earliest);
        }
      }
      if (stopping_) return;
      // Take out what is due: the new requests (read once), those whose job finished,
      // those past their deadline.
      const auto now = std::chrono::steady_clock::now();
      std::vector<Waiting> rest;
      for (auto& w : waiting_)
        (!w.checked || finished_.count(w.id) || now >= w.deadline ? due : rest)
            .push_back(std::move(w));
      waiting_.swap(rest);
      finished_.clear();
      unchecked_ = false;
    }
    answer_due(std::move(due), false);
  }
}

}  // namespace camlab::service
