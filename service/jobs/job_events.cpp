#include "service/jobs/job_events.h"

#include <algorithm>

namespace camlab::service {

JobEvents::~JobEvents() { stop(); }

void JobEvents::start() {
  std::lock_guard lock(mutex_);
  if (started_ || stopping_) return;
  started_ = true;
  thread_ = std::thread([this] { run(); });
}

void JobEvents::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::list<std::shared_ptr<Subscriber>> left;
  {
    std::lock_guard lock(mutex_);
    left.swap(subscribers_);
  }
  for (auto& s : left) {
    Deliver deliver = std::move(s->deliver);
    s->closed = true;
    if (deliver) deliver(make_error("shutting_down", "camlabd is shutting down"));
  }
}

void JobEvents::publish(const JobChange& change) {
  {
    std::lock_guard lock(mutex_);
    for (auto& s : subscribers_) {
      if (s->resync) continue;
      auto same_job = std::find_if(s->pending.begin(), s->pending.end(),
                                   [&](const JobChange& c) { return c.id == change.id; });
      if (same_job != s->pending.end()) {
        *same_job = change;
      } else if (s->pending.size() >= kMaxPendingJobs) {
        s->pending.clear();
        s->resync = true;
      } else {
        s->pending.push_back(change);
      }
    }
  }
  wake_.notify_all();
}

Result<std::shared_ptr<JobEvents::Subscription>> JobEvents::subscribe() {
  auto subscriber = std::make_shared<Subscriber>();
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return make_error("shutting_down", "camlabd is shutting down");
    if (static_cast<int>(subscribers_.size()) >= kMaxSubscribers)
      return make_error("too_many_connections",
                        "there are already " + std::to_string(subscribers_.size()) +
                            " event streams open (limit " + std::to_string(kMaxSubscribers) + ")");
    subscriber->last_delivery = std::chrono::steady_clock::now();
    subscribers_.push_back(subscriber);
  }
  return std::make_shared<Subscription>(this, std::move(subscriber));
}

void JobEvents::Subscription::next(Deliver deliver) {
  {
    std::lock_guard lock(events_->mutex_);
    if (!events_->stopping_) {
      if (subscriber_->closed) return;
      subscriber_->deliver = std::move(deliver);
      deliver = nullptr;
    }
  }
  // The hub has stopped: nobody would answer later.
  if (deliver) return deliver(make_error("shutting_down", "camlabd is shutting down"));
  events_->wake_.notify_all();
}

void JobEvents::Subscription::close() { events_->unsubscribe(subscriber_); }

void JobEvents::unsubscribe(const std::shared_ptr<Subscriber>& subscriber) {
  Deliver dropped;  // destroyed after the lock is released (see run())
  std::lock_guard lock(mutex_);
  subscriber->closed = true;
  dropped = std::move(subscriber->deliver);
  subscriber->deliver = nullptr;
  subscribers_.remove(subscriber);
}

void JobEvents::run() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    const auto now = std::chrono::steady_clock::now();
    auto wake_at = now + kHeartbeat;
    std::vector<std::pair<Deliver, JobEventBatch>> due;
    for (auto& s : subscribers_) {
      if (!s->deliver) continue;
      const bool has_news = s->resync || !s->pending.empty();
      const auto batch_at = s->last_delivery + kMinBatchInterval;
      const auto heartbeat_at = s->last_delivery + kHeartbeat;
      if ((has_news && now >= batch_at) || now >= heartbeat_at) {
        JobEventBatch batch;
        batch.changes.swap(s->pending);
        batch.resync = s->resync;
        s->resync = false;
        s->last_delivery = now;
        due.emplace_back(std::move(s->deliver), std::move(batch));
        s->deliver = nullptr;
      } else {
        wake_at = std::min(wake_at, has_news ? batch_at : heartbeat_at);
      }
    }
    if (due.empty()) {
      wake_.wait_until(lock, wake_at);
      continue;
    }
    lock.unlock();
    for (auto& [deliver, batch] : due) deliver(std::move(batch));
    // Destroyed before the lock is taken again: a callback may hold the last reference to
    // its HTTP session, whose stream then unsubscribes under this same lock.
    due.clear();
    lock.lock();
  }
}

}  // namespace camlab::service
