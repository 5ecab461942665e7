// Trying a database operation again while the database is unavailable, with a bounded
// backoff (job_store.h, "A database that cannot be reached"), and the names that make a
// write tried again apply once.
//
// Reentrant.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <random>
#include <string>
#include <thread>

#include "base/result.h"

namespace camlab::service {

inline bool is_database_unavailable(const Status& status) {
  return !status.ok() && status.error().code == ErrorCode::kDatabaseUnavailable;
}
template <class T>
bool is_database_unavailable(const Result<T>& result) {
  return !result.ok() && result.error().code == ErrorCode::kDatabaseUnavailable;
}

// Runs `attempt()` (returning a Result or a Status) with `mutex` held; while it fails
// with database_unavailable and `patience` allows, waits with the lock released (backoff
// doubling from 50 ms to 1 s) and runs it again. The last outcome is returned.
template <class Attempt>
auto retry_while_unavailable(std::chrono::milliseconds patience, std::mutex& mutex,
                             Attempt&& attempt) -> decltype(attempt()) {
  using namespace std::chrono;
  const auto deadline = steady_clock::now() + patience;
  milliseconds backoff(50);
  for (;;) {
    {
      std::lock_guard lock(mutex);
      auto outcome = attempt();
      if (!is_database_unavailable(outcome) || steady_clock::now() + backoff > deadline)
        return outcome;
    }
    // Released while waiting: other callers fail fast meanwhile rather than queue up.
    std::this_thread::sleep_for(backoff);
    backoff = std::min(backoff * 2, milliseconds(1000));
  }
}

// 64 random bits as hex. A writer names its operations by this and a counter, so that two
// writers (two hosts, or a host and its restarted self) never name one the same.
inline std::string new_operation_prefix() {
  std::random_device device;
  const uint64_t bits = (static_cast<uint64_t>(device()) << 32) ^ device();
  char text[24];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(bits));
  return text;
}

}  // namespace camlab::service
