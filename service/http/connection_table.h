// The open HTTP connections and what each is doing, for admission at
// HttpLimits::max_connections. A connection is waiting for a request (an idle keep-alive
// connection, or a client still sending its request line and headers), being answered
// (its handler is working, or a stream waits for its next piece), or writing its answer
// to the client. When the server is full, the connection that has waited longest for a
// request gives way, or failing that the one blocked longest writing to a client that does
// not read; either only after a second, so a client that just connected gets its chance:
// held-open, dribbling and never-reading connections cannot lock other clients out (the
// reviews' 256 idle connections, then 256 that pipelined requests and read nothing, kept
// every other client, health checks included, out for 15 s, then 35-41 s), while a
// handler at work is never cut.
//
// Thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace camlab::service {

class HttpSession;

class ConnectionTable {
 public:
  using Clock = std::chrono::steady_clock;

  // Registers a session from `address` (the peer's IP, as text) as waiting for a
  // request; returns its id.
  uint64_t add(std::weak_ptr<HttpSession> session, std::string address);
  // Open sessions from `address`.
  int count_from(const std::string& address);
  void remove(uint64_t id);
  // The session waits for (the rest of) a request from now on.
  void waiting(uint64_t id);
  // The session's request is being answered (not the client's to hold up).
  void answering(uint64_t id);
  // The session writes its answer, which the client must read.
  void writing(uint64_t id);
  // The session to close to make room: the one that has waited longest for a request,
  // else the one blocked longest writing, either for at least `min_wait` and still alive;
  // it is no longer a candidate afterwards. Null when none qualifies.
  // With `address`, only that address's sessions are considered (one address at its own
  // limit gives way to itself, not to others).
  std::shared_ptr<HttpSession> take_evictable(Clock::duration min_wait,
                                              const std::string* address = nullptr);

 private:
  enum class Activity { kWaitingForRequest, kAnswering, kWriting, kEvicted };
  struct Entry {
    std::weak_ptr<HttpSession> session;
    std::string address;
    Clock::time_point since;
    Activity activity = Activity::kWaitingForRequest;
  };
  void set(uint64_t id, Activity activity);

  std::mutex mutex_;
  std::map<uint64_t, Entry> entries_;
  uint64_t next_id_ = 1;
};

}  // namespace camlab::service
