// The SQLite wrapper (service/store/sqlite_statement.h) on a private in-memory database:
// every value comes back exactly as bound, every failure is an error value with SQLite's
// reason, and a statement is reset after each use and can be used again.
#include "service/store/sqlite_statement.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace camlab::service::sqlite {
namespace {

using namespace std::string_literals;

class StatementTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto opened = Connection::open(":memory:");
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    db_ = std::move(*opened);
    ASSERT_TRUE(db_.execute_script("CREATE TABLE t (i INTEGER, r REAL, s TEXT, u TEXT UNIQUE)"));
  }

  Statement prepare(const std::string& sql) {
    auto prepared = Statement::prepare(db_, sql);
    EXPECT_TRUE(prepared.ok()) << sql << ": " << prepared.error().message;
    return prepared.ok() ? std::move(*prepared) : Statement();
  }

  int64_t count_rows() {
    Statement count = prepare("SELECT COUNT(*) FROM t");
    int64_t rows = -1;
    EXPECT_TRUE(count.query([&](const Statement& row) { rows = row.column_int64(0); }));
    return rows;
  }

  Connection db_;
};

TEST_F(StatementTest, Int64ExtremesRoundTrip) {
  const std::vector<int64_t> values = {std::numeric_limits<int64_t>::min(),
                                       std::numeric_limits<int64_t>::min() + 1,
                                       -1,
                                       0,
                                       1,
                                       int64_t{1} << 53,
                                       (int64_t{1} << 53) + 1,  // beyond a double's precision
                                       std::numeric_limits<int64_t>::max()};
  Statement insert = prepare("INSERT INTO t (i) VALUES (?)");
  for (int64_t value : values) {
    auto changed = insert.execute(value);
    ASSERT_TRUE(changed.ok()) << changed.error().message;
    EXPECT_EQ(*changed, 1);
  }
  std::vector<int64_t> read;
  Statement select = prepare("SELECT i, typeof(i) FROM t ORDER BY rowid");
  ASSERT_TRUE(select.query([&](const Statement& row) {
    EXPECT_EQ(row.column_text(1), "integer");
    read.push_back(row.column_int64(0));
  }));
  EXPECT_EQ(read, values);
}

TEST_F(StatementTest, SmallIntegersAndBoolsBindAsIntegers) {
  Statement select = prepare("SELECT ?, ?, ?, ?");
  ASSERT_TRUE(
      select.bind_all(std::numeric_limits<int>::min(), true, uint32_t{4000000000u}, short{-7}));
  auto step = select.step();
  ASSERT_TRUE(step.ok());
  ASSERT_EQ(*step, Step::kRow);
  EXPECT_EQ(select.column_int(0), std::numeric_limits<int>::min());
  EXPECT_EQ(select.column_int64(1), 1);
  EXPECT_EQ(select.column_int64(2), 4000000000);
  EXPECT_EQ(select.column_int64(3), -7);
}

TEST_F(StatementTest, DoublesRoundTripExactly) {
  const std::vector<double> values = {0.0,
                                      -0.0,
                                      0.1,
                                      1.0 / 3.0,
                                      M_PI,
                                      -1e308,
                                      std::numeric_limits<double>::denorm_min(),
                                      std::numeric_limits<double>::max(),
                                      std::numeric_limits<double>::lowest(),
                                      std::numeric_limits<double>::infinity(),
                                      -std::numeric_limits<double>::infinity()};
  Statement insert = prepare("INSERT INTO t (r) VALUES (?)");
  for (double value : values) ASSERT_TRUE(insert.execute(value).ok());
  std::vector<double> read;
  Statement select = prepare("SELECT r FROM t ORDER BY rowid");
  ASSERT_TRUE(select.query([&](const Statement& row) { read.push_back(row.column_double(0)); }));
  ASSERT_EQ(read.size(), values.size());
  // Equal as doubles: -0.0 reads back as +0.0, SQLite storing an integral REAL as an
  // integer (its own choice, not the wrapper's).
  for (size_t i = 0; i < values.size(); ++i) EXPECT_EQ(read[i], values[i]) << i;
}

TEST_F(StatementTest, TextRoundTripsWithQuotesAndEmbeddedNuls) {
  const std::vector<std::string> values = {
      "",
      "it's a \"quoted\" 'text'; DROP TABLE t; --",
      "a\0b"s,
      "\0"s,
      "trailing\0"s,
      "\xc3\xa9t\xc3\xa9 \xe2\x82\xac",  // UTF-8: été €
      std::string(1 << 20, 'x') + "\0end"s,
  };
  Statement insert = prepare("INSERT INTO t (s) VALUES (?)");
  for (const std::string& value : values) ASSERT_TRUE(insert.execute(value).ok());
  std::vector<std::string> read;
  Statement select = prepare("SELECT s, length(CAST(s AS BLOB)), typeof(s) FROM t ORDER BY rowid");
  ASSERT_TRUE(select.query([&](const Statement& row) {
    read.push_back(row.column_text(0));
    // SQLite holds every byte (not a C string cut at the first NUL), as text, not NULL.
    EXPECT_EQ(row.column_int64(1), static_cast<int64_t>(read.back().size()));
    EXPECT_EQ(row.column_text(2), "text");
    EXPECT_FALSE(row.column_is_null(0));
  }));
  EXPECT_EQ(read, values);
  // The text is matched as bound: a parameter is never spliced into the SQL.
  Statement find = prepare("SELECT COUNT(*) FROM t WHERE s = ?");
  int64_t found = 0;
  ASSERT_TRUE(find.query([&](const Statement& row) { found = row.column_int64(0); }, values[1]));
  EXPECT_EQ(found, 1);
}

TEST_F(StatementTest, NullsAndOptionalsRoundTrip) {
  Statement insert = prepare("INSERT INTO t (i, r, s) VALUES (?, ?, ?)");
  ASSERT_TRUE(insert.execute(nullptr, std::nullopt, std::optional<std::string>()).ok());
  const auto present = insert.execute(std::optional<int64_t>(42), std::optional<double>(2.5),
                                      std::optional<std::string>("here"));
  ASSERT_TRUE(present.ok());
  Statement null_by_hand = prepare("INSERT INTO t (i, r, s) VALUES (?, ?, ?)");
  ASSERT_TRUE(null_by_hand.bind_null(1));
  ASSERT_TRUE(null_by_hand.bind_null(2));
  ASSERT_TRUE(null_by_hand.bind_null(3));
  ASSERT_TRUE(null_by_hand.step().ok());

  struct Row {
    bool null_i, null_r, null_s;
    std::optional<std::string> s;
    int64_t i;
    double r;
  };
  std::vector<Row> rows;
  Statement select = prepare("SELECT i, r, s FROM t ORDER BY rowid");
  ASSERT_TRUE(select.query([&](const Statement& row) {
    rows.push_back({row.column_is_null(0), row.column_is_null(1), row.column_is_null(2),
                    row.column_optional_text(2), row.column_int64(0), row.column_double(1)});
  }));
  ASSERT_EQ(rows.size(), 3u);
  for (const Row& row : {rows[0], rows[2]}) {
    EXPECT_TRUE(row.null_i && row.null_r && row.null_s);
    EXPECT_EQ(row.s, std::nullopt);
    EXPECT_EQ(row.i, 0);
    EXPECT_EQ(row.r, 0.0);
  }
  EXPECT_FALSE(rows[1].null_i || rows[1].null_r || rows[1].null_s);
  EXPECT_EQ(rows[1].i, 42);
  EXPECT_EQ(rows[1].r, 2.5);
  EXPECT_EQ(rows[1].s, std::optional<std::string>("here"));
}

TEST_F(StatementTest, MalformedSqlIsAnErrorValue) {
  for (const std::string& sql :
       {"SELEC 1"s, "SELECT * FROM no_such_table"s, "INSERT INTO t (i) VALUES ("s, ""s, "  ;  "s,
        "-- only a comment"s, "SELECT 1; SELECT 2"s, "SELECT 1\0 trailing"s}) {
    auto prepared = Statement::prepare(db_, sql);
    ASSERT_FALSE(prepared.ok()) << sql;
    EXPECT_EQ(prepared.error().code, ErrorCode::kIoError) << sql;
    EXPECT_NE(prepared.error().message.find("cannot prepare"), std::string::npos);
  }
  auto syntax = Statement::prepare(db_, "SELEC 1");
  ASSERT_FALSE(syntax.ok());
  EXPECT_NE(syntax.error().message.find("syntax error"), std::string::npos)
      << syntax.error().message;
  EXPECT_NE(syntax.error().message.find("SELEC 1"), std::string::npos);
  auto missing = Statement::prepare(db_, "SELECT * FROM no_such_table");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("no such table: no_such_table"), std::string::npos);
  // The connection is unharmed.
  EXPECT_EQ(count_rows(), 0);
}

TEST_F(StatementTest, ConstraintViolationIsAnErrorValueAndChangesNothing) {
  Statement insert = prepare("INSERT INTO t (u) VALUES (?)");
  ASSERT_TRUE(insert.execute("once").ok());
  auto again = insert.execute("once");
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code, ErrorCode::kIoError);
  EXPECT_NE(again.error().message.find("UNIQUE constraint failed: t.u"), std::string::npos)
      << again.error().message;
  EXPECT_EQ(count_rows(), 1);
  // The failed statement was reset: it takes the next value at once.
  auto other = insert.execute("other");
  ASSERT_TRUE(other.ok()) << other.error().message;
  EXPECT_EQ(count_rows(), 2);

  ASSERT_TRUE(db_.execute_script("CREATE TABLE checked (x INTEGER NOT NULL CHECK (x > 0))"));
  Statement checked = prepare("INSERT INTO checked (x) VALUES (?)");
  auto negative = checked.execute(-1);
  ASSERT_FALSE(negative.ok());
  EXPECT_NE(negative.error().message.find("CHECK constraint failed"), std::string::npos);
  auto null = checked.execute(nullptr);
  ASSERT_FALSE(null.ok());
  EXPECT_NE(null.error().message.find("NOT NULL constraint failed: checked.x"), std::string::npos);
}

TEST_F(StatementTest, WrongBindsAreErrorValues) {
  Statement insert = prepare("INSERT INTO t (i, s) VALUES (?, ?)");
  auto too_few = insert.execute(1);
  ASSERT_FALSE(too_few.ok());
  EXPECT_EQ(too_few.error().code, ErrorCode::kInternal);
  EXPECT_NE(too_few.error().message.find("takes 2 parameters, given 1"), std::string::npos);
  auto too_many = insert.execute(1, "a", 2.0);
  ASSERT_FALSE(too_many.ok());
  EXPECT_EQ(too_many.error().code, ErrorCode::kInternal);
  const Status out_of_range = insert.bind(3, int64_t{1});
  ASSERT_FALSE(out_of_range.ok());
  EXPECT_EQ(out_of_range.error().code, ErrorCode::kIoError);
  EXPECT_NE(out_of_range.error().message.find("parameter 3"), std::string::npos);
  EXPECT_EQ(count_rows(), 0);
}

TEST_F(StatementTest, AStatementNeverPreparedFailsCleanly) {
  Statement nothing;
  EXPECT_EQ(nothing.bind(1, int64_t{1}).error().code, ErrorCode::kInternal);
  EXPECT_EQ(nothing.step().error().code, ErrorCode::kInternal);
  EXPECT_EQ(nothing.execute().error().code, ErrorCode::kInternal);
  nothing.reset();
  EXPECT_EQ(nothing.column_count(), 0);
  EXPECT_TRUE(nothing.column_is_null(0));
  EXPECT_EQ(nothing.column_text(0), "");
  EXPECT_EQ(nothing.sql(), "");
}

TEST_F(StatementTest, ColumnsOutsideARowReadAsNull) {
  Statement select = prepare("SELECT 7, 'x'");
  EXPECT_EQ(select.column_count(), 2);
  EXPECT_TRUE(select.column_is_null(0));  // no row yet
  EXPECT_EQ(select.column_int64(0), 0);
  auto step = select.step();
  ASSERT_TRUE(step.ok());
  ASSERT_EQ(*step, Step::kRow);
  EXPECT_EQ(select.column_int64(0), 7);
  EXPECT_EQ(select.column_text(1), "x");
  EXPECT_TRUE(select.column_is_null(2));  // beyond the last column
  EXPECT_TRUE(select.column_is_null(-1));
  EXPECT_EQ(select.column_text(5), "");
  step = select.step();
  ASSERT_TRUE(step.ok());
  EXPECT_EQ(*step, Step::kDone);
  EXPECT_TRUE(select.column_is_null(0));  // past the end
}

TEST_F(StatementTest, StatementsResetAndAreReusable) {
  Statement insert = prepare("INSERT INTO t (i) VALUES (?)");
  for (int64_t i = 0; i < 100; ++i) ASSERT_TRUE(insert.execute(i).ok());
  EXPECT_EQ(count_rows(), 100);

  // query() resets after reading: the same statement reads the same rows again, with
  // other bindings.
  Statement below = prepare("SELECT i FROM t WHERE i < ? ORDER BY i");
  for (int64_t limit : {10, 3, 10, 0}) {
    std::vector<int64_t> read;
    ASSERT_TRUE(
        below.query([&](const Statement& row) { read.push_back(row.column_int64(0)); }, limit));
    ASSERT_EQ(read.size(), static_cast<size_t>(limit));
    for (int64_t i = 0; i < limit; ++i) EXPECT_EQ(read[i], i);
  }

  // One step at a time: a read stopped after its first row starts over after reset(), and
  // reset() clears the bindings (an unbound parameter is NULL).
  Statement echo = prepare("SELECT ?, i FROM t ORDER BY i");
  ASSERT_TRUE(echo.bind(1, "first"));
  ASSERT_EQ(*echo.step(), Step::kRow);
  ASSERT_EQ(*echo.step(), Step::kRow);
  EXPECT_EQ(echo.column_int64(1), 1);
  echo.reset();
  ASSERT_EQ(*echo.step(), Step::kRow);
  EXPECT_TRUE(echo.column_is_null(0));
  EXPECT_EQ(echo.column_int64(1), 0);
  echo.reset();
  ASSERT_TRUE(echo.bind(1, 2.5));
  ASSERT_EQ(*echo.step(), Step::kRow);
  EXPECT_EQ(echo.column_double(0), 2.5);
}

TEST_F(StatementTest, ExecuteCountsTheRowsChanged) {
  Statement insert = prepare("INSERT INTO t (i) VALUES (?)");
  for (int64_t i = 0; i < 5; ++i) ASSERT_TRUE(insert.execute(i).ok());
  Statement update = prepare("UPDATE t SET s = 'big' WHERE i >= ?");
  EXPECT_EQ(*update.execute(2), 3);
  EXPECT_EQ(*update.execute(10), 0);
  // A read changes nothing, whatever the last write changed.
  EXPECT_EQ(*prepare("SELECT i FROM t").execute(), 0);
  Statement remove = prepare("DELETE FROM t WHERE s IS NULL");
  EXPECT_EQ(*remove.execute(), 2);
  EXPECT_EQ(count_rows(), 3);
}

TEST_F(StatementTest, PersistentStatementsBehaveTheSame) {
  auto insert =
      Statement::prepare(db_, "INSERT INTO t (i) VALUES (?)", Statement::Lifetime::kPersistent);
  ASSERT_TRUE(insert.ok());
  for (int64_t i = 0; i < 3; ++i) ASSERT_TRUE(insert->execute(i).ok());
  EXPECT_EQ(count_rows(), 3);
  EXPECT_EQ(insert->sql(), "INSERT INTO t (i) VALUES (?)");
}

TEST(SqliteConnection, OpeningWhereNoFileCanBeIsAnErrorValue) {
  auto opened = Connection::open("/nonexistent-camlab-dir/sub/jobs.sqlite");
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.error().code, ErrorCode::kIoError);
  EXPECT_NE(opened.error().message.find("/nonexistent-camlab-dir/sub/jobs.sqlite"),
            std::string::npos);
}

TEST(SqliteConnection, ScriptErrorsAreErrorValues) {
  auto opened = Connection::open(":memory:");
  ASSERT_TRUE(opened.ok());
  const Status broken = opened->execute_script("CREATE TABLE a (x); CREATE TABLEE b (y)");
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.error().code, ErrorCode::kIoError);
  EXPECT_NE(broken.error().message.find("syntax error"), std::string::npos);
  Connection closed;
  EXPECT_FALSE(closed.execute_script("SELECT 1").ok());
  EXPECT_FALSE(Statement::prepare(closed, "SELECT 1").ok());
}

}  // namespace
}  // namespace camlab::service::sqlite
