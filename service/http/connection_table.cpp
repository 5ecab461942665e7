#include "service/http/connection_table.h"

namespace camlab::service {

uint64_t ConnectionTable::add(std::weak_ptr<HttpSession> session, std::string address) {
  std::lock_guard lock(mutex_);
  const uint64_t id = next_id_++;
  entries_[id] =
      Entry{std::move(session), std::move(address), Clock::now(), Activity::kWaitingForRequest};
  return id;
}

int ConnectionTable::count_from(const std::string& address) {
  std::lock_guard lock(mutex_);
  int n = 0;
  for (const auto& [id, entry] : entries_) n += entry.address == address ? 1 : 0;
  return n;
}

void ConnectionTable::remove(uint64_t id) {
  std::lock_guard lock(mutex_);
  entries_.erase(id);
}

void ConnectionTable::set(uint64_t id, Activity activity) {
  std::lock_guard lock(mutex_);
  auto it = entries_.find(id);
  // An evicted session is closing: it is not offered again, whatever it does meanwhile.
  if (it == entries_.end() || it->second.activity == Activity::kEvicted) return;
  if (it->second.activity != activity) it->second.since = Clock::now();
  it->second.activity = activity;
}

void ConnectionTable::waiting(uint64_t id) { set(id, Activity::kWaitingForRequest); }
void ConnectionTable::answering(uint64_t id) { set(id, Activity::kAnswering); }
void ConnectionTable::writing(uint64_t id) { set(id, Activity::kWriting); }

std::shared_ptr<HttpSession> ConnectionTable::take_evictable(Clock::duration min_wait,
                                                             const std::string* address) {
  std::lock_guard lock(mutex_);
  const Clock::time_point latest = Clock::now() - min_wait;
  for (Activity wanted : {Activity::kWaitingForRequest, Activity::kWriting}) {
    auto oldest = entries_.end();
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->second.activity == wanted && it->second.since <= latest &&
          (!address || it->second.address == *address) &&
          (oldest == entries_.end() || it->second.since < oldest->second.since))
        oldest = it;
    if (oldest == entries_.end()) continue;
    oldest->second.activity = Activity::kEvicted;
    if (auto session = oldest->second.session.lock()) return session;
  }
  return nullptr;
}

}  // namespace camlab::service
