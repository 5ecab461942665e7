#include "service/store/sqlite_statement.h"

#include <sqlite3.h>

#include <climits>

namespace camlab::service::sqlite {

namespace {

// SQL for a message: quoted, and cut short so that a long statement keeps the message
// readable.
std::string quote_sql(std::string_view sql) {
  constexpr size_t kMaxChars = 120;
  if (sql.size() <= kMaxChars) return "\"" + std::string(sql) + "\"";
  return "\"" + std::string(sql.substr(0, kMaxChars)) + "...\"";
}

bool is_blank(std::string_view text) {
  return text.find_first_not_of(" \t\r\n;") == std::string_view::npos;
}

Error never_prepared() {
  return make_error("internal", "SQLite: using a statement that was never prepared");
}

}  // namespace

// --- Connection ---

Result<Connection> Connection::open(const std::filesystem::path& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(
      path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
  // Owned from here: even a failed open may leave a handle to close.
  Connection connection(db);
  if (rc != SQLITE_OK) {
    return make_error("io_error", "cannot open the database " + path.string() + ": " +
                                      (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc)));
  }
  return connection;
}

Connection::Connection(Connection&& other) noexcept : db_(std::exchange(other.db_, nullptr)) {}

Connection& Connection::operator=(Connection&& other) noexcept {
  if (this != &other) {
    close();
    db_ = std::exchange(other.db_, nullptr);
  }
  return *this;
}

Connection::~Connection() { close(); }

void Connection::close() {
  // close_v2: should a statement still be open, the connection closes when it is finalized
  // rather than staying open for good.
  if (db_) sqlite3_close_v2(db_);
  db_ = nullptr;
}

void Connection::set_busy_timeout(int timeout_ms) {
  if (db_) sqlite3_busy_timeout(db_, timeout_ms);
}

Status Connection::execute_script(const std::string& sql) {
  if (!db_) return make_error("internal", "SQLite: using a connection that is not open");
  char* message = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
    Error error = make_error("io_error", message ? message : sqlite3_errmsg(db_));
    sqlite3_free(message);
    return error;
  }
  return {};
}

int64_t Connection::last_insert_rowid() const { return db_ ? sqlite3_last_insert_rowid(db_) : 0; }

// --- Statement ---

Result<Statement> Statement::prepare(const Connection& connection, std::string_view sql,
                                     Lifetime lifetime) {
  sqlite3* db = connection.get();
  if (!db) return make_error("internal", "SQLite: preparing on a connection that is not open");
  if (sql.size() > static_cast<size_t>(INT_MAX))
    return make_error("io_error", "cannot prepare " + quote_sql(sql) + ": the SQL is too long");
  sqlite3_stmt* stmt = nullptr;
  const char* tail = nullptr;
  const int rc = sqlite3_prepare_v3(
      db, sql.data() ? sql.data() : "", static_cast<int>(sql.size()),
      lifetime == Lifetime::kPersistent ? SQLITE_PREPARE_PERSISTENT : 0, &stmt, &tail);
  Statement statement(stmt);  // finalized on every path below
  if (rc != SQLITE_OK)
    return make_error("io_error", "cannot prepare " + quote_sql(sql) + ": " + sqlite3_errmsg(db));
  if (!stmt)
    return make_error("io_error", "cannot prepare " + quote_sql(sql) + ": it holds no statement");
  // SQLite compiles only the first statement and would ignore the rest without a word.
  const std::string_view rest = tail ? sql.substr(static_cast<size_t>(tail - sql.data())) : "";
  if (!is_blank(rest))
    return make_error("io_error",
                      "cannot prepare " + quote_sql(sql) + ": it holds more than one statement");
  return statement;
}

Statement& Statement::operator=(Statement&& other) noexcept {
  if (this != &other) {
    sqlite3_finalize(stmt_);
    stmt_ = std::exchange(other.stmt_, nullptr);
    has_row_ = std::exchange(other.has_row_, false);
  }
  return *this;
}

Statement::~Statement() { sqlite3_finalize(stmt_); }  // a no-op on nullptr

Status Statement::bind_result(int index, int rc) const {
  if (rc == SQLITE_OK) return {};
  // sqlite3_errstr, not errmsg: a misused bind leaves the connection's message as it was.
  return make_error("io_error", "cannot bind parameter " + std::to_string(index) + " of " +
                                    quote_sql(sql()) + ": " + sqlite3_errstr(rc));
}

Status Statement::bind(int index, int64_t value) {
  if (!stmt_) return never_prepared();
  return bind_result(index, sqlite3_bind_int64(stmt_, index, value));
}

Status Statement::bind(int index, double value) {
  if (!stmt_) return never_prepared();
  return bind_result(index, sqlite3_bind_double(stmt_, index, value));
}

Status Statement::bind(int index, std::string_view text) {
  if (!stmt_) return never_prepared();
  // A null pointer would bind NULL, not "": an empty string_view may carry one.
  return bind_result(index, sqlite3_bind_text64(stmt_, index, text.data() ? text.data() : "",
                                                text.size(), SQLITE_TRANSIENT, SQLITE_UTF8));
}

Status Statement::bind_null(int index) {
  if (!stmt_) return never_prepared();
  return bind_result(index, sqlite3_bind_null(stmt_, index));
}

Status Statement::check_parameter_count(int given) const {
  if (!stmt_) return never_prepared();
  const int expected = sqlite3_bind_parameter_count(stmt_);
  if (given == expected) return {};
  return make_error("internal", quote_sql(sql()) + " takes " + std::to_string(expected) +
                                    " parameters, given " + std::to_string(given));
}

Result<Step> Statement::step() {
  has_row_ = false;
  if (!stmt_) return never_prepared();
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) {
    has_row_ = true;
    return Step::kRow;
  }
  if (rc == SQLITE_DONE) return Step::kDone;
  // With a statement from prepare_v3, the code and the connection's message are this
  // step's ("UNIQUE constraint failed: jobs.id", "database is locked").
  return make_error("io_error", sqlite3_errmsg(sqlite3_db_handle(stmt_)));
}

void Statement::reset() {
  has_row_ = false;
  if (!stmt_) return;
  // Its result repeats the last step's error, which that step has already returned.
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

Result<int> Statement::run_to_end() {
  while (true) {
    Step stepped;
    CAMLAB_ASSIGN(stepped, step());
    if (stepped == Step::kDone) break;
  }
  // sqlite3_changes keeps the last writing statement's count: a read changes nothing.
  return sqlite3_stmt_readonly(stmt_) ? 0 : sqlite3_changes(sqlite3_db_handle(stmt_));
}

bool Statement::readable(int column) const {
  return stmt_ && has_row_ && column >= 0 && column < sqlite3_data_count(stmt_);
}

int Statement::column_count() const { return stmt_ ? sqlite3_column_count(stmt_) : 0; }

bool Statement::column_is_null(int column) const {
  return !readable(column) || sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}

int64_t Statement::column_int64(int column) const {
  return readable(column) ? sqlite3_column_int64(stmt_, column) : 0;
}

int Statement::column_int(int column) const {
  return readable(column) ? sqlite3_column_int(stmt_, column) : 0;
}

double Statement::column_double(int column) const {
  return readable(column) ? sqlite3_column_double(stmt_, column) : 0.0;
}

std::string Statement::column_text(int column) const {
  if (!readable(column)) return "";
  // Text first, then its length: the order SQLite documents for a converted value.
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  const int bytes = sqlite3_column_bytes(stmt_, column);
  if (!text) return "";
  return std::string(reinterpret_cast<const char*>(text), static_cast<size_t>(bytes));
}

std::optional<std::string> Statement::column_optional_text(int column) const {
  if (column_is_null(column)) return std::nullopt;
  return column_text(column);
}

std::string Statement::sql() const {
  const char* text = stmt_ ? sqlite3_sql(stmt_) : nullptr;
  return text ? text : "";
}

}  // namespace camlab::service::sqlite
