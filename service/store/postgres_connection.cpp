#include "service/store/postgres_connection.h"

#include <libpq-fe.h>
#include <sys/socket.h>

#include <algorithm>
#include <map>
#include <vector>

namespace camlab::service::postgres {

namespace {

using Clock = std::chrono::steady_clock;

// 'value' quoted for a libpq key=value string.
std::string quoted(const std::string& value) {
  std::string out = "'";
  for (char c : value) {
    if (c == '\\' || c == '\'') out.push_back('\\');
    out.push_back(c);
  }
  return out + "'";
}

// The URL's parameters (PQconninfoParse reads both the URI and the key=value form) with
// camlab's defaults for the ones it leaves unset, as a key=value string; on a parse error,
// the URL as given (the connect then names the problem).
std::string conninfo_with_defaults(const ConnectOptions& options) {
  char* message = nullptr;
  PQconninfoOption* parsed = PQconninfoParse(options.url.c_str(), &message);
  if (!parsed) {
    PQfreemem(message);
    return options.url;
  }
  std::map<std::string, std::string> given;
  for (PQconninfoOption* o = parsed; o->keyword; ++o)
    if (o->val) given[o->keyword] = o->val;
  PQconninfoFree(parsed);
  const auto timeout_s = std::max<int64_t>(
      2, std::chrono::duration_cast<std::chrono::seconds>(options.connect_timeout).count());
  const std::map<std::string, std::string> defaults = {
      {"connect_timeout", std::to_string(timeout_s)},
      {"application_name", "camlabd"},
      // A peer that is gone is found within about 10 s between statements.
      {"keepalives", "1"},
      {"keepalives_idle", "5"},
      {"keepalives_interval", "2"},
      {"keepalives_count", "3"},
      // Data unacknowledged this long fails the connection (kernel-level).
      {"tcp_user_timeout", std::to_string(options.statement_timeout.count())}};
  for (const auto& [key, value] : defaults) given.emplace(key, value);
  std::string conninfo;
  for (const auto& [key, value] : given)
    conninfo += (conninfo.empty() ? "" : " ") + key + "=" + quoted(value);
  return conninfo;
}

// SQLSTATEs that mean the server or the link is going away or not there yet: class 08
// (connection exception), 57P01-57P03 (admin or crash shutdown, cannot connect now),
// 53300 (too many connections).
bool is_unavailable_state(const std::string& state) {
  return state.rfind("08", 0) == 0 || state == "57P01" || state == "57P02" || state == "57P03" ||
         state == "53300";
}

// The first line of libpq's message (it adds hints on further lines).
std::string first_line(const std::string& text) {
  std::string line = text.substr(0, text.find('\n'));
  while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.pop_back();
  return line;
}

}  // namespace

std::string redacted_url(const std::string& url) {
  std::string out = url;
  // postgresql://user:password@host/...: the password is between the user's ':' and '@'.
  if (const size_t scheme = out.find("://"); scheme != std::string::npos) {
    const size_t at = out.find('@', scheme + 3);
    const size_t colon = out.find(':', scheme + 3);
    if (at != std::string::npos && colon != std::string::npos && colon < at)
      out.replace(colon + 1, at - colon - 1, "***");
  }
  // password=... in either form (a query parameter or a key=value pair).
  for (size_t at = out.find("password="); at != std::string::npos;
       at = out.find("password=", at + 1)) {
    const size_t start = at + 9;
    const size_t end = out.find_first_of(" &", start);
    out.replace(start, (end == std::string::npos ? out.size() : end) - start, "***");
  }
  return out;
}

Connection::Connection(ConnectOptions options, OnConnect on_connect, OnDisconnect on_disconnect)
    : options_(std::move(options)),
      conninfo_(conninfo_with_defaults(options_)),
      on_connect_(std::move(on_connect)),
      on_disconnect_(std::move(on_disconnect)) {
  watchdog_ = std::thread([this] { watch(); });
}

Connection::~Connection() {
  {
    std::lock_guard lock(watch_mutex_);
    watch_stop_ = true;
  }
  watch_wake_.notify_all();
  watchdog_.join();
  drop();
}

void Connection::drop() {
  if (conn_ && on_disconnect_) on_disconnect_();
  conn_.reset();
  backend_pid_ = 0;
}

Status Connection::ensure_connected(const char* what) {
  if (conn_) return {};
  const auto now = Clock::now();
  if (now < next_connect_)
    return make_error("database_unavailable",
                      std::string("database: ") + what + ": the database at " +
                          redacted_url(options_.url) + " is unreachable; connecting again in " +
                          std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(
                                             next_connect_ - now)
                                             .count()) +
                          " ms");
  try {
    conn_ = std::make_unique<pqxx::connection>(conninfo_);
    if (on_connect_) on_connect_(*conn_);
    backend_pid_ = conn_->backendpid();
    backoff_ = std::chrono::milliseconds(0);
    return {};
  } catch (const std::exception& e) {
    drop();
    backoff_ =
        std::clamp(backoff_ * 2, std::chrono::milliseconds(100), options_.reconnect_backoff_max);
    next_connect_ = Clock::now() + backoff_;
    // A connect that fails is the server's absence, whatever libpq calls it.
    return make_error("database_unavailable",
                      std::string("database: ") + what + ": cannot connect to " +
                          redacted_url(options_.url) + ": " + first_line(e.what()));
  }
}

Status Connection::use(const char* what, const std::function<void(pqxx::connection&)>& body) {
  if (Status connected = ensure_connected(what); !connected) return connected;
  try {
    body(*conn_);
    return {};
  } catch (...) {
    return failure(what, std::current_exception());
  }
}

Error Connection::failure(const char* what, std::exception_ptr thrown) {
  const std::string step = std::string("database: ") + what + ": ";
  const std::string lost = step + "connection to " + redacted_url(options_.url) + " lost";
  bool timed_out = false;
  {
    std::lock_guard lock(watch_mutex_);
    std::swap(timed_out, timed_out_);
  }
  try {
    std::rethrow_exception(thrown);
  } catch (const pqxx::broken_connection& e) {
    drop();
    if (timed_out)
      return make_error("database_unavailable",
                        lost + ": no answer within " +
                            std::to_string(options_.statement_timeout.count()) + " ms");
    return make_error("database_unavailable", lost + ": " + first_line(e.what()));
  } catch (const pqxx::in_doubt_error& e) {
    drop();
    return make_error("database_unavailable", lost + " while committing: " + first_line(e.what()));
  } catch (const pqxx::statement_completion_unknown& e) {
    drop();
    return make_error("database_unavailable",
                      lost + " during the statement: " + first_line(e.what()));
  } catch (const pqxx::transaction_rollback& e) {
    // Serialization failure or deadlock: the transaction is to be run again.
    return make_error("database_unavailable",
                      step + "transaction to be retried: " + first_line(e.what()));
  } catch (const pqxx::sql_error& e) {
    if (is_unavailable_state(e.sqlstate())) {
      drop();
      return make_error("database_unavailable", step + redacted_url(options_.url) +
                                                    " is unavailable (SQLSTATE " + e.sqlstate() +
                                                    "): " + first_line(e.what()));
    }
    return make_error("io_error", step + first_line(e.what()) + " (SQLSTATE " + e.sqlstate() + ")");
  } catch (const std::exception& e) {
    // libpqxx reports a connection it found closed as a plain failure in some paths.
    if (conn_ && !conn_->is_open()) {
      drop();
      return make_error("database_unavailable", lost + ": " + first_line(e.what()));
    }
    return make_error("io_error", step + first_line(e.what()));
  } catch (...) {
    return make_error("internal", step + "unexpected exception");
  }
}

void Connection::arm() {
  {
    std::lock_guard lock(watch_mutex_);
    watched_fd_ = conn_ ? conn_->sock() : -1;
    deadline_ = Clock::now() + options_.statement_timeout;
    timed_out_ = false;
  }
  watch_wake_.notify_all();
}

void Connection::disarm() {
  std::lock_guard lock(watch_mutex_);
  watched_fd_ = -1;
}

void Connection::watch() {
  std::unique_lock lock(watch_mutex_);
  while (!watch_stop_) {
    if (watched_fd_ < 0) {
      watch_wake_.wait(lock);
      continue;
    }
    const auto deadline = deadline_;
    if (watch_wake_.wait_until(lock, deadline) == std::cv_status::timeout && watched_fd_ >= 0 &&
        deadline_ == deadline) {
      // shutdown, not close: the fd stays libpq's; its blocked read returns at once.
      ::shutdown(watched_fd_, SHUT_RDWR);
      timed_out_ = true;
      watched_fd_ = -1;
    }
  }
}

}  // namespace camlab::service::postgres
