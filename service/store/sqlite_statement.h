// SQLite behind values: a Connection owns an open database and a Statement owns one
// prepared statement on it. Every failure comes back as an Error carrying SQLite's own
// message (io_error; binding the wrong number of values, a bug, is internal), never as an
// exception or a crash, so that a query reads as its SQL plus its binds:
//
//   CAMLAB_ASSIGN(changed, statement.execute(unix_time_ms(), id));  // ?1, ?2; then reset
//
// sqlite3.h is not included here (its types are only declared), so the job store's header,
// which the handlers see, does not bring SQLite with it.
#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "base/result.h"

struct sqlite3;
struct sqlite3_stmt;

namespace camlab::service::sqlite {

// An open database connection, closed when its owner goes.
//
// Thread-compatible. It is opened without SQLite's own locking (SQLITE_OPEN_NOMUTEX): its
// owner serializes every use of it and of its statements (the job store holds one mutex).
class Connection {
 public:
  // Opens `path` read-write, creating it when missing; ":memory:" is a private database in
  // memory.
  static Result<Connection> open(const std::filesystem::path& path);

  Connection() = default;
  Connection(Connection&& other) noexcept;
  Connection& operator=(Connection&& other) noexcept;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  ~Connection();

  sqlite3* get() const { return db_; }
  // How long a statement waits for a lock another connection holds before failing busy.
  void set_busy_timeout(int timeout_ms);
  // Runs `;`-separated statements that return no rows (pragmas, the schema, BEGIN/COMMIT).
  Status execute_script(const std::string& sql);
  // The rowid of the last successful INSERT on this connection.
  int64_t last_insert_rowid() const;

 private:
  explicit Connection(sqlite3* db) : db_(db) {}
  void close();

  sqlite3* db_ = nullptr;
};

// What one step gave: a row to read with the column accessors, or the end.
enum class Step { kRow, kDone };

// One prepared statement: finalized when its owner goes. Parameters are numbered from 1
// (`?`, `?NNN`), columns from 0, as in SQLite.
//
// execute() and query() bind, run and reset in one call: a statement is reset after every
// use, so it holds no read snapshot between uses (a held snapshot would keep the WAL from
// being checkpointed) and can be used again at once. bind(), step() and reset() are the
// same steps one at a time.
//
// Thread-compatible: used under its connection's owner's lock, like the connection.
class Statement {
 public:
  // kPersistent tells SQLite the statement will be kept and reused many times.
  enum class Lifetime { kOnce, kPersistent };

  // Compiles one SQL statement; malformed SQL, or text holding no statement or more than
  // one, is an error value naming the SQL.
  static Result<Statement> prepare(const Connection& connection, std::string_view sql,
                                   Lifetime lifetime = Lifetime::kOnce);

  Statement() = default;
  Statement(Statement&& other) noexcept
      : stmt_(std::exchange(other.stmt_, nullptr)),
        has_row_(std::exchange(other.has_row_, false)) {}
  Statement& operator=(Statement&& other) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement();

  // Typed binds of parameter `index`. Text is copied, embedded NULs included.
  Status bind(int index, int64_t value);
  Status bind(int index, double value);
  Status bind(int index, std::string_view text);
  Status bind_null(int index);
  Status bind(int index, std::nullptr_t) { return bind_null(index); }
  Status bind(int index, std::nullopt_t) { return bind_null(index); }
  // int, bool and the other integers, as int64 (a uint64_t might not fit: not accepted).
  // (An int64_t takes the overload above: a function beats a template in a tie.)
  template <std::integral T>
  Status bind(int index, T value) {
    static_assert(std::is_signed_v<T> || sizeof(T) < sizeof(int64_t),
                  "SQLite stores integers as int64: this type may not fit");
    return bind(index, static_cast<int64_t>(value));
  }
  // NULL when empty.
  template <class T>
  Status bind(int index, const std::optional<T>& value) {
    return value ? bind(index, *value) : bind_null(index);
  }
  // Binds `args` to parameters 1..N in order; N must be the statement's parameter count.
  template <class... Args>
  Status bind_all(const Args&... args) {
    Status status = check_parameter_count(static_cast<int>(sizeof...(Args)));
    int index = 0;
    (void)index;  // unused when there is nothing to bind
    (void)(status.ok() && ((status = bind(++index, args)).ok() && ...));
    return status;
  }

  // Runs the statement to its next row, or to its end.
  Result<Step> step();
  // Back to the start, with every parameter NULL again, ending any read the statement holds
  // open.
  void reset();

  // Resets, binds `args` to parameters 1..N, runs to the end and resets again. Returns the
  // rows an INSERT, UPDATE or DELETE changed (0 for other statements).
  template <class... Args>
  Result<int> execute(const Args&... args) {
    reset();
    ResetOnExit reset_on_exit{this};
    if (Status bound = bind_all(args...); !bound) return bound.error();
    return run_to_end();
  }
  // Resets, binds `args` to parameters 1..N and calls `on_row(const Statement&)` for each
  // row, reading it with the column accessors; resets again at the end.
  template <class OnRow, class... Args>
  Status query(OnRow&& on_row, const Args&... args) {
    reset();
    ResetOnExit reset_on_exit{this};
    if (Status bound = bind_all(args...); !bound) return bound;
    while (true) {
      Result<Step> stepped = step();
      if (!stepped) return stepped.error();
      if (*stepped == Step::kDone) return {};
      on_row(std::as_const(*this));
    }
  }

  // The current row's columns. Read before a row, or beyond the last column, a column is
  // NULL: 0, 0.0 and "" (never undefined behaviour).
  int column_count() const;
  bool column_is_null(int column) const;
  int64_t column_int64(int column) const;
  int column_int(int column) const;
  double column_double(int column) const;
  std::string column_text(int column) const;  // embedded NULs kept; NULL reads as ""
  std::optional<std::string> column_optional_text(int column) const;  // NULL: nullopt

  // The SQL the statement was prepared from, for messages.
  std::string sql() const;

 private:
  struct ResetOnExit {
    Statement* statement;
    ~ResetOnExit() { statement->reset(); }
  };

  explicit Statement(sqlite3_stmt* stmt) : stmt_(stmt) {}
  Status check_parameter_count(int given) const;
  Status bind_result(int index, int rc) const;
  Result<int> run_to_end();
  bool readable(int column) const;

  sqlite3_stmt* stmt_ = nullptr;
  bool has_row_ = false;  // the last step gave a row and no reset came since
};

}  // namespace camlab::service::sqlite
