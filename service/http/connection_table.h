// The open HTTP connections and what each is doing, for admission at
// HttpLimits::max_connections. A connection is either waiting for a request (an idle
// keep-alive connection, or a client still sending its request line and headers) or
// busy (its request is being answered). When the server is full, the connection that
// has waited longest for a request, if it has waited at least a second, is closed to make
// room: held-open or dribbling connections cannot lock other clients out (the review's
// 256 idle connections made every other client, health checks included, get a reset),
// while a request being answered is never cut.
//
// Thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>

namespace camlab::service {

class HttpSession;

class ConnectionTable {
 public:
  using Clock = std::chrono::steady_clock;

  // Registers a session (as waiting); returns its id.
  uint64_t add(std::weak_ptr<HttpSession> session);
  void remove(uint64_t id);
  // The session waits for (the rest of) a request from now on.
  void waiting(uint64_t id);
  // The session's request is being answered.
  void busy(uint64_t id);
  // The session that has waited longest for a request, if it has waited at least
  // `min_wait` and is still alive; it is no longer a candidate afterwards.
  std::shared_ptr<HttpSession> take_longest_waiting(Clock::duration min_wait);

 private:
  struct Entry {
    std::weak_ptr<HttpSession> session;
    Clock::time_point waiting_since;
    bool waiting = true;
  };
  std::mutex mutex_;
  std::map<uint64_t, Entry> entries_;
  uint64_t next_id_ = 1;
};

}  // namespace camlab::service
