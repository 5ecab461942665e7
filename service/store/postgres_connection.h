// One PostgreSQL connection (libpqxx) that reconnects on demand and turns every failure
// into an Error: the only code in camlab that catches libpqxx's exceptions.
//
// - A connection lost or refused (the server restarting, the network cut), a commit whose
//   outcome is unknown, or a server that says it is shutting down or starting up, is
//   "database_unavailable": the connection is dropped, and the next call connects again,
//   no sooner than the backoff (doubling from 100 ms to `reconnect_backoff_max` while
//   connecting fails), so that a server that is down costs one refused connect per
//   backoff, not one per call. A serialization failure or deadlock is database_unavailable
//   too (the transaction is to be run again), keeping the connection.
// - Any other SQL error is "io_error" naming the step and the server's message (a bug or
//   a schema problem: retrying would not help).
//
// A network that drops packets without a reset would leave a statement waiting forever,
// so every statement runs under a client-side deadline (`statement_timeout`): a watchdog
// thread shuts the socket down when it passes, which fails the statement as a lost
// connection. libpq's keepalives and tcp_user_timeout are set too (unless the URL sets
// them), which find a dead peer between statements.
//
// Thread-compatible: its owner serialises every call (a mutex of its own).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <type_traits>

#include <pqxx/pqxx>

#include "base/result.h"

namespace camlab::service::postgres {

struct ConnectOptions {
  std::string url;  // libpq URI (postgresql://...) or key=value string
  std::chrono::milliseconds connect_timeout{3000};
  std::chrono::milliseconds statement_timeout{10000};
  std::chrono::milliseconds reconnect_backoff_max{2000};
};

// The URL without its password, for messages and logs.
std::string redacted_url(const std::string& url);

class Connection {
 public:
  // Run on every new connection (preparing statements, LISTEN); may throw pqxx errors,
  // which fail the connect like any other.
  using OnConnect = std::function<void(pqxx::connection&)>;
  // Run before a connection is closed (what was bound to it, such as notification
  // receivers, must go first).
  using OnDisconnect = std::function<void()>;

  Connection(ConnectOptions options, OnConnect on_connect, OnDisconnect on_disconnect = {});
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // Runs `body(pqxx::work&)` (returning a value) in one transaction and commits it; the
  // body's value, or the error. `what` names the step in messages ("database: start job: ...").
  template <class Body>
  auto transact(const char* what, Body&& body) -> Result<std::invoke_result_t<Body&, pqxx::work&>>;

  // Runs `body(pqxx::connection&)` on the connection (connecting first), outside any
  // transaction (waiting for notifications).
  Status use(const char* what, const std::function<void(pqxx::connection&)>& body);

  // The server process serving this connection (0 when not connected): the notifications
  // this connection's transactions send carry it.
  int backend_pid() const { return backend_pid_.load(); }
  bool connected() const { return conn_ != nullptr; }
  const ConnectOptions& options() const { return options_; }

 private:
  Status ensure_connected(const char* what);
  // The error for an exception thrown inside `what`; drops the connection when it is lost.
  Error failure(const char* what, std::exception_ptr thrown);
  void drop();
  // The statement watchdog: arm before a round trip, disarm after.
  void arm();
  void disarm();
  void watch();

  const ConnectOptions options_;
  const std::string conninfo_;  // the URL with camlab's defaults added
  const OnConnect on_connect_;
  const OnDisconnect on_disconnect_;
  std::unique_ptr<pqxx::connection> conn_;
  std::atomic<int> backend_pid_{0};
  std::chrono::steady_clock::time_point next_connect_{};
  std::chrono::milliseconds backoff_{0};

  std::mutex watch_mutex_;
  std::condition_variable watch_wake_;
  int watched_fd_ = -1;  // the socket of the statement in flight, -1 when none
  std::chrono::steady_clock::time_point deadline_{};
  bool timed_out_ = false;
  bool watch_stop_ = false;
  std::thread watchdog_;
};

template <class Body>
auto Connection::transact(const char* what, Body&& body)
    -> Result<std::invoke_result_t<Body&, pqxx::work&>> {
  if (Status connected = ensure_connected(what); !connected) return connected.error();
  arm();
  try {
    pqxx::work tx(*conn_);
    auto value = body(tx);
    tx.commit();
    disarm();
    return value;
  } catch (...) {
    disarm();
    return failure(what, std::current_exception());
  }
}

}  // namespace camlab::service::postgres
