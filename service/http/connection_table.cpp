#include "service/http/connection_table.h"

namespace camlab::service {

uint64_t ConnectionTable::add(std::weak_ptr<HttpSession> session) {
  std::lock_guard lock(mutex_);
  const uint64_t id = next_id_++;
  entries_[id] = Entry{std::move(session), Clock::now(), true};
  return id;
}

void ConnectionTable::remove(uint64_t id) {
  std::lock_guard lock(mutex_);
  entries_.erase(id);
}

void ConnectionTable::waiting(uint64_t id) {
  std::lock_guard lock(mutex_);
  if (auto it = entries_.find(id); it != entries_.end()) {
    it->second.waiting = true;
    it->second.waiting_since = Clock::now();
  }
}

void ConnectionTable::busy(uint64_t id) {
  std::lock_guard lock(mutex_);
  if (auto it = entries_.find(id); it != entries_.end()) it->second.waiting = false;
}

std::shared_ptr<HttpSession> ConnectionTable::take_longest_waiting(Clock::duration min_wait) {
  std::lock_guard lock(mutex_);
  const Clock::time_point latest = Clock::now() - min_wait;
  auto oldest = entries_.end();
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->second.waiting && it->second.waiting_since <= latest &&
        (oldest == entries_.end() || it->second.waiting_since < oldest->second.waiting_since))
      oldest = it;
  if (oldest == entries_.end()) return nullptr;
  oldest->second.waiting = false;  // taken: not offered twice while it closes
  return oldest->second.session.lock();
}

}  // namespace camlab::service
