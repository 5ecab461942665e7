// The job store (service/store/job_store.h) on both of its databases, with the same tests:
// SQLite in a temporary folder always, and PostgreSQL in a throwaway cluster of its own
// (tests/support/pg_cluster.h) when the server binaries are installed. What is written
// reads back the same, across a reopen too, and the state transitions only go the
// documented ways. SQLite's own file handling is tested at the end.
#include "service/store/job_store.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "service/store/open_job_store.h"
#include "service/store/sqlite_job_store.h"
#include "service/store/sqlite_statement.h"
#include "tests/support/pg_cluster.h"

// Each database as the typed tests see it (at global scope, so that the tests' names read
// JobStoreTest.Name<JobStoreOnPostgres>): prepare() gives a fresh, empty store's place (or
// why there can be none here), open() opens it (again).
struct JobStoreOnSqlite {
  std::string prepare(const std::filesystem::path& folder) {
    path_ = folder / "camlabd.sqlite";
    return "";
  }
  camlab::Result<std::unique_ptr<camlab::service::JobStore>> open() {
    return camlab::service::JobStore::open(path_);
  }
  std::filesystem::path path_;
};

struct JobStoreOnPostgres {
  std::string prepare(const std::filesystem::path&) {
    if (std::string missing = camlab::testing::PgCluster::missing(); !missing.empty())
      return missing;
    std::string error;
    if (!cluster_.start(&error)) return "FAIL " + error;
    if (!cluster_.create_database("jobs")) return "FAIL cannot create the database";
    return "";
  }
  camlab::Result<std::unique_ptr<camlab::service::JobStore>> open() {
    camlab::service::StoreConfig config;
    config.db = cluster_.url("jobs");
    config.host_name = "host-a";
    return camlab::service::open_job_store(config);
  }
  camlab::testing::PgCluster cluster_;
};

namespace camlab::service {
namespace {

namespace fs = std::filesystem;

// A fresh folder per test, removed afterwards.
class TempFolder {
 public:
  TempFolder() {
    std::string pattern = (fs::temp_directory_path() / "camlab_job_store_XXXXXX").string();
    if (::mkdtemp(pattern.data())) path_ = pattern;
  }
  ~TempFolder() {
    std::error_code ignored;
    if (!path_.empty()) fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

template <class Database>
class JobStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(folder_.path().empty());
    const std::string why = database_.prepare(folder_.path());
    if (why.rfind("FAIL ", 0) == 0) FAIL() << why;
    if (!why.empty()) GTEST_SKIP() << why;
    reopen();
  }
  void reopen() {
    store_.reset();
    auto opened = database_.open();
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    store_ = std::move(*opened);
  }
  // A second store on the same database (another connection).
  std::unique_ptr<JobStore> open_another() {
    auto opened = database_.open();
    EXPECT_TRUE(opened.ok()) << opened.error().message;
    return opened ? std::move(*opened) : nullptr;
  }

  TempFolder folder_;
  Database database_;
  std::unique_ptr<JobStore> store_;
};

using Databases = ::testing::Types<JobStoreOnSqlite, JobStoreOnPostgres>;
TYPED_TEST_SUITE(JobStoreTest, Databases);

TYPED_TEST(JobStoreTest, AJobReadsBackAsWritten) {
  const nlohmann::json request = {{"kind", "single"},
                                  {"note", "it's \"quoted\"; DROP TABLE jobs; --"},
                                  {"unicode", "\xc3\xa9t\xc3\xa9"},
                                  {"frames", 3},
                                  {"gain", 1.25}};
  const int64_t before_ms = unix_time_ms();
  auto created = this->store_->create("capture", "vcam0", request, "captures/job-", 3);
  ASSERT_TRUE(created.ok()) << created.error().message;
  const JobRecord& job = *created;
  EXPECT_GT(job.id, 0);
  EXPECT_EQ(job.folder, "captures/job-" + std::string(6 - std::to_string(job.id).size(), '0') +
                            std::to_string(job.id));
  EXPECT_GE(job.created_ms, before_ms);
  EXPECT_LE(job.created_ms, unix_time_ms());

  auto read = this->store_->get(job.id);
  ASSERT_TRUE(read.ok()) << read.error().message;
  ASSERT_TRUE(read->has_value());
  const JobRecord& stored = **read;
  EXPECT_EQ(stored.id, job.id);
  EXPECT_EQ(stored.kind, "capture");
  EXPECT_EQ(stored.camera_id, "vcam0");
  EXPECT_EQ(stored.state, JobState::kQueued);
  EXPECT_EQ(stored.request, request);
  EXPECT_EQ(stored.folder, job.folder);
  EXPECT_EQ(stored.created_ms, job.created_ms);
  EXPECT_EQ(stored.started_ms, 0);
  EXPECT_EQ(stored.finished_ms, 0);
  EXPECT_EQ(stored.frames_total, 3);
  EXPECT_EQ(stored.frames_done, 0);
  EXPECT_TRUE(stored.error_code.empty());
  EXPECT_TRUE(stored.result.is_null());
  EXPECT_EQ(to_json(stored), to_json(job));

  // The same after the daemon restarts.
  this->reopen();
  auto again = this->store_->get(job.id);
  ASSERT_TRUE(again.ok() && again->has_value());
  EXPECT_EQ(to_json(**again), to_json(stored));
}

TYPED_TEST(JobStoreTest, AJobWithoutAFolderPrefixHasNoFolder) {
  auto created = this->store_->create("analysis", "", nlohmann::json::object(), "", 0);
  ASSERT_TRUE(created.ok());
  EXPECT_TRUE(created->folder.empty());
  auto read = this->store_->get(created->id);
  ASSERT_TRUE(read.ok() && read->has_value());
  EXPECT_TRUE((*read)->folder.empty());
  EXPECT_TRUE((*read)->camera_id.empty());
}

TYPED_TEST(JobStoreTest, AMissingJobIsNoJob) {
  auto read = this->store_->get(12345);
  ASSERT_TRUE(read.ok());
  EXPECT_FALSE(read->has_value());
}

TYPED_TEST(JobStoreTest, TransitionsGoOnlyTheDocumentedWays) {
  const int64_t id = this->store_->create("capture", "vcam0", {{"n", 1}}, "captures/job-", 4)->id;
  EXPECT_TRUE(this->store_->progress(id, 1, 4, 0).ok());  // not running yet: ignored
  EXPECT_EQ((*this->store_->get(id))->frames_done, 0);

  EXPECT_TRUE(*this->store_->start(id));
  EXPECT_FALSE(*this->store_->start(id));  // already running
  EXPECT_FALSE(*this->store_->cancel_queued(id));
  ASSERT_TRUE(this->store_->progress(id, 3, 4, 1).ok());
  JobRecord running = **this->store_->get(id);
  EXPECT_EQ(running.state, JobState::kRunning);
  EXPECT_GT(running.started_ms, 0);
  EXPECT_EQ(running.frames_done, 3);
  EXPECT_EQ(running.frames_discarded, 1);

  const nlohmann::json result = {{"frames", 3}, {"mean", 0.5}};
  EXPECT_TRUE(*this->store_->finish(id, JobState::kFailed, make_error("timeout", "no frame in 2 s"),
                                    result));
  // A finished job is never overwritten.
  EXPECT_FALSE(*this->store_->finish(id, JobState::kSucceeded, std::nullopt, nullptr));
  const JobRecord finished = **this->store_->get(id);
  EXPECT_EQ(finished.state, JobState::kFailed);
  EXPECT_EQ(finished.error_code, "timeout");
  EXPECT_EQ(finished.error_message, "no frame in 2 s");
  EXPECT_EQ(finished.result, result);
  EXPECT_GE(finished.finished_ms, finished.started_ms);

  const int64_t queued = this->store_->create("capture", "vcam0", {{"n", 2}}, "", 1)->id;
  EXPECT_TRUE(*this->store_->cancel_queued(queued));
  EXPECT_FALSE(*this->store_->start(queued));
  const JobRecord cancelled = **this->store_->get(queued);
  EXPECT_EQ(cancelled.state, JobState::kCancelled);
  EXPECT_EQ(cancelled.error_code, "cancelled");
  EXPECT_TRUE(cancelled.result.is_null());
}

// The change observer (server-sent events) sees every step of a job in order, with the
// progress as reported, and nothing for a report on a job that is not running or for a
// transition the store refused.
TYPED_TEST(JobStoreTest, TheChangeObserverSeesEveryStepInOrder) {
  std::vector<JobChange> seen;
  this->store_->set_change_observer([&seen](const JobChange& change) { seen.push_back(change); });
  const int64_t id = this->store_->create("capture", "vcam0", {{"n", 1}}, "captures/job-", 4)->id;
  ASSERT_TRUE(this->store_->progress(id, 1, 4, 0).ok());  // not running: not shown
  ASSERT_TRUE(*this->store_->start(id));
  ASSERT_FALSE(*this->store_->start(id));
  ASSERT_TRUE(this->store_->progress(id, 2, 4, 1).ok());
  ASSERT_TRUE(this->store_->progress(id, 4, 4, 3).ok());
  ASSERT_TRUE(*this->store_->finish(id, JobState::kSucceeded, std::nullopt, {{"frames", 4}}));
  ASSERT_FALSE(*this->store_->finish(id, JobState::kFailed, std::nullopt, nullptr));
  ASSERT_TRUE(this->store_->progress(id, 5, 4, 3).ok());  // finished: not shown
  const int64_t queued = this->store_->create("analysis", "", nlohmann::json::object(), "", 0)->id;
  ASSERT_TRUE(*this->store_->cancel_queued(queued));

  struct Expected {
    int64_t id;
    JobState state;
    int done, total, discarded;
  };
  const std::vector<Expected> expected = {
      {id, JobState::kQueued, 0, 4, 0},       {id, JobState::kRunning, 0, 0, 0},
      {id, JobState::kRunning, 2, 4, 1},      {id, JobState::kRunning, 4, 4, 3},
      {id, JobState::kSucceeded, 4, 4, 3},    {queued, JobState::kQueued, 0, 0, 0},
      {queued, JobState::kCancelled, 0, 0, 0}};
  ASSERT_EQ(seen.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE("change " + std::to_string(i));
    EXPECT_EQ(seen[i].id, expected[i].id);
    EXPECT_EQ(seen[i].state, expected[i].state);
    EXPECT_EQ(seen[i].frames_done, expected[i].done);
    EXPECT_EQ(seen[i].frames_total, expected[i].total);
    EXPECT_EQ(seen[i].frames_discarded, expected[i].discarded);
  }
}

// Progress is kept in memory and written to the database only now and then: a reader racing
// the writer never sees less than what progress() had returned from before the read began,
// nor a count going back; list() agrees; the database row lags by fewer than
// kProgressRowFrames + 1 frames; and the finished row (read after a reopen) holds the last
// count.
TYPED_TEST(JobStoreTest, ProgressReadDuringACaptureIsNeverBehindTheLastReport) {
  constexpr int kFrames = 300;
  // In turn first: each read shows the report just made, through get() and list().
  const int64_t in_turn = this->store_->create("capture", "vcam0", {{"n", 0}}, "", kFrames)->id;
  ASSERT_TRUE(*this->store_->start(in_turn));
  for (int k = 1; k <= kFrames; ++k) {
    ASSERT_TRUE(this->store_->progress(in_turn, k, kFrames, k / 10).ok());
    const JobRecord job = **this->store_->get(in_turn);
    ASSERT_EQ(job.frames_done, k);
    ASSERT_EQ(job.frames_discarded, k / 10);
    ASSERT_EQ((*this->store_->list(JobState::kRunning, 1, 0))[0].frames_done, k);
  }
  ASSERT_TRUE(*this->store_->finish(in_turn, JobState::kSucceeded, std::nullopt, nullptr));

  // Then racing: the camera's thread reports while this one reads.
  const int64_t id = this->store_->create("capture", "vcam0", {{"n", 1}}, "", kFrames)->id;
  ASSERT_TRUE(*this->store_->start(id));
  std::atomic<int> reported{0};
  std::atomic<bool> done{false};
  std::thread camera([&] {
    for (int k = 1; k <= kFrames; ++k) {
      EXPECT_TRUE(this->store_->progress(id, k, kFrames, k / 10).ok());
      reported.store(k);
    }
    done.store(true);
  });
  int last_seen = 0, reads = 0, behind = 0, backwards = 0;
  while (!done.load() || reads < 10) {
    const int before = reported.load();
    auto job = this->store_->get(id);
    ASSERT_TRUE(job.ok() && job->has_value());
    const int seen = (*job)->frames_done;
    if (seen < before) ++behind;
    if (seen < last_seen) ++backwards;
    EXPECT_EQ((*job)->frames_discarded, seen / 10);  // one report, never mixed
    last_seen = seen;
    ++reads;
  }
  camera.join();
  EXPECT_EQ(behind, 0);
  EXPECT_EQ(backwards, 0);
  auto listed = this->store_->list(JobState::kRunning, 10, 0);
  ASSERT_TRUE(listed.ok());
  ASSERT_EQ(listed->size(), 1u);
  EXPECT_EQ((*listed)[0].frames_done, kFrames);

  // A second connection reads the row as the database holds it.
  ASSERT_TRUE(this->store_->progress(id, kFrames - 1, kFrames, 0).ok());  // not due: memory only
  {
    auto other = this->open_another();
    ASSERT_TRUE(other);
    const JobRecord row = **other->get(id);
    EXPECT_GE(row.frames_done, kFrames - 1 - kProgressRowFrames);
    EXPECT_LE(row.frames_done, kFrames);
  }
  ASSERT_TRUE(this->store_->progress(id, kFrames - 2, kFrames, 2).ok());
  ASSERT_TRUE(*this->store_->finish(id, JobState::kSucceeded, std::nullopt, {{"ok", true}}));
  this->reopen();
  const JobRecord finished = **this->store_->get(id);
  EXPECT_EQ(finished.frames_done, kFrames - 2);
  EXPECT_EQ(finished.frames_discarded, 2);
}

// Finished jobs are served from memory once read: more of them than the cache holds, read
// twice each, all read back as written, the first of them too (from the database again).
TYPED_TEST(JobStoreTest, FinishedJobsReadBackTheSameBeyondTheCache) {
  const int count = static_cast<int>(kFinishedCacheJobs) + 10;
  std::vector<int64_t> ids;
  for (int i = 0; i < count; ++i) {
    const int64_t id = this->store_->create("capture", "vcam0", {{"i", i}}, "", 1)->id;
    ASSERT_TRUE(*this->store_->finish(id, JobState::kSucceeded, std::nullopt, {{"twice", 2 * i}}));
    ids.push_back(id);
  }
  for (int pass = 0; pass < 2; ++pass)
    for (int i = 0; i < count; ++i) {
      const JobRecord job = **this->store_->get(ids[i]);
      ASSERT_EQ(job.id, ids[i]);
      ASSERT_EQ(job.state, JobState::kSucceeded);
      ASSERT_EQ(job.request, nlohmann::json({{"i", i}}));
      ASSERT_EQ(job.result, nlohmann::json({{"twice", 2 * i}}));
    }
}

// A crash-restart's interruption writes the progress that only memory held.
TYPED_TEST(JobStoreTest, InterruptingWritesTheProgressHeldInMemory) {
  const int64_t id = this->store_->create("capture", "vcam0", {{"n", 1}}, "", 100)->id;
  ASSERT_TRUE(*this->store_->start(id));
  for (int k = 1; k <= 7; ++k) ASSERT_TRUE(this->store_->progress(id, k, 100, 0).ok());
  EXPECT_EQ(*this->store_->interrupt_unfinished("camlabd stopped"), 1);
  this->reopen();
  const JobRecord job = **this->store_->get(id);
  EXPECT_EQ(job.state, JobState::kInterrupted);
  EXPECT_EQ(job.frames_done, 7);
}

TYPED_TEST(JobStoreTest, ListsCountsAndInterrupts) {
  std::vector<int64_t> ids;
  for (int i = 0; i < 5; ++i)
    ids.push_back(this->store_->create("capture", "vcam0", {{"i", i}}, "", 1)->id);
  ASSERT_TRUE(*this->store_->start(ids[1]));
  ASSERT_TRUE(*this->store_->finish(ids[2], JobState::kSucceeded, std::nullopt, {{"ok", true}}));

  auto all = this->store_->list(std::nullopt, 10, 0);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 5u);
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ((*all)[i].id, ids[4 - i]);  // newest first
  auto page = this->store_->list(std::nullopt, 2, 1);
  ASSERT_TRUE(page.ok());
  ASSERT_EQ(page->size(), 2u);
  EXPECT_EQ((*page)[0].id, ids[3]);
  EXPECT_EQ((*page)[1].id, ids[2]);
  auto queued = this->store_->list(JobState::kQueued, 10, 0);
  ASSERT_TRUE(queued.ok());
  EXPECT_EQ(queued->size(), 3u);
  for (const JobRecord& job : *queued) EXPECT_EQ(job.state, JobState::kQueued);

  auto counts = this->store_->count_by_state();
  ASSERT_TRUE(counts.ok());
  EXPECT_EQ(*counts,
            (std::map<std::string, int64_t>{{"queued", 3}, {"running", 1}, {"succeeded", 1}}));

  // A restart after a crash: every unfinished job becomes interrupted, once.
  this->reopen();
  auto interrupted = this->store_->interrupt_unfinished("camlabd stopped");
  ASSERT_TRUE(interrupted.ok());
  EXPECT_EQ(*interrupted, 4);
  EXPECT_EQ(*this->store_->interrupt_unfinished("again"), 0);
  const JobRecord was_running = **this->store_->get(ids[1]);
  EXPECT_EQ(was_running.state, JobState::kInterrupted);
  EXPECT_EQ(was_running.error_message, "camlabd stopped");
  EXPECT_EQ((**this->store_->get(ids[2])).state, JobState::kSucceeded);
}

TYPED_TEST(JobStoreTest, LatencyReadsBackAndIsReplaced) {
  auto none = this->store_->latency("vcam0");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());

  LatencyRecord probe{"vcam0", 2, "probe", 1700000000123, {{"trace", {1, 2, 3}}}};
  ASSERT_TRUE(this->store_->put_latency(probe).ok());
  auto read = this->store_->latency("vcam0");
  ASSERT_TRUE(read.ok() && read->has_value());
  EXPECT_EQ((*read)->camera_id, "vcam0");
  EXPECT_EQ((*read)->latency_frames, 2);
  EXPECT_EQ((*read)->source, "probe");
  EXPECT_EQ((*read)->measured_ms, 1700000000123);
  EXPECT_EQ((*read)->details, probe.details);

  LatencyRecord spec{"vcam0", 1, "spec", 1700000000999, nlohmann::json::object()};
  ASSERT_TRUE(this->store_->put_latency(spec).ok());
  this->reopen();
  read = this->store_->latency("vcam0");
  ASSERT_TRUE(read.ok() && read->has_value());
  EXPECT_EQ((*read)->latency_frames, 1);
  EXPECT_EQ((*read)->source, "spec");
  EXPECT_EQ((*read)->details, nlohmann::json::object());
  EXPECT_FALSE(this->store_->latency("vcam1")->has_value());
}

// SQLite's own file: its mode, its schema version, migration, and a file that is none.
class SqliteJobStoreTest : public JobStoreTest<JobStoreOnSqlite> {
 protected:
  fs::path database() const { return database_.path_; }
};

TEST_F(SqliteJobStoreTest, TheDatabaseIsInWalModeWithTheSchemaVersion) {
  auto db = sqlite::Connection::open(database());
  ASSERT_TRUE(db.ok());
  for (const auto& [sql, expected] :
       {std::pair<const char*, std::string>{"PRAGMA journal_mode", "wal"},
        {"PRAGMA user_version", std::to_string(kSchemaVersion)}}) {
    auto read = sqlite::Statement::prepare(*db, sql);
    ASSERT_TRUE(read.ok());
    std::string value;
    ASSERT_TRUE(read->query([&](const sqlite::Statement& row) { value = row.column_text(0); }));
    EXPECT_EQ(value, expected) << sql;
  }
}

TEST_F(SqliteJobStoreTest, ANewerSchemaIsRefused) {
  store_.reset();
  {
    auto db = sqlite::Connection::open(database());
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE(db->execute_script("PRAGMA user_version=" + std::to_string(kSchemaVersion + 1)));
  }
  auto opened = JobStore::open(database());
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.error().code, ErrorCode::kUnsupported);
}

TEST_F(SqliteJobStoreTest, AVersion1DatabaseIsMigratedKeepingItsJobs) {
  store_.reset();
  fs::remove(database());
  {
    // The version-1 schema as it shipped: its CHECK has no 'device_lost'.
    auto db = sqlite::Connection::open(database());
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE(db->execute_script(R"sql(
      CREATE TABLE jobs (
        id INTEGER PRIMARY KEY AUTOINCREMENT, kind TEXT NOT NULL,
        camera_id TEXT NOT NULL DEFAULT '',
        state TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed',
                                             'cancelled', 'interrupted')),
        request TEXT NOT NULL, folder TEXT NOT NULL DEFAULT '', created_ms INTEGER NOT NULL,
        started_ms INTEGER NOT NULL DEFAULT 0, finished_ms INTEGER NOT NULL DEFAULT 0,
        frames_done INTEGER NOT NULL DEFAULT 0, frames_total INTEGER NOT NULL DEFAULT 0,
        frames_discarded INTEGER NOT NULL DEFAULT 0, error_code TEXT NOT NULL DEFAULT '',
        error_message TEXT NOT NULL DEFAULT '', result TEXT);
      CREATE INDEX jobs_by_state ON jobs (state);
      CREATE TABLE devices (camera_id TEXT PRIMARY KEY, latency_frames INTEGER NOT NULL,
        latency_source TEXT NOT NULL, measured_ms INTEGER NOT NULL, details TEXT NOT NULL);
      INSERT INTO jobs (kind, camera_id, state, request, folder, created_ms, frames_done)
        VALUES ('capture', 'v4l2:old', 'succeeded', '{"kind":"single"}', 'captures/job-000001',
                1700000000000, 4);
      INSERT INTO jobs (kind, camera_id, state, request, created_ms)
        VALUES ('capture', 'v4l2:old', 'running', '{}', 1700000000001);
      PRAGMA user_version=1;)sql"));
    // The old schema refuses the new state: the migration is what makes it storable.
    EXPECT_FALSE(db->execute_script("UPDATE jobs SET state = 'device_lost' WHERE id = 2").ok());
  }
  reopen();
  ASSERT_TRUE(store_);
  const JobRecord old = **store_->get(1);
  EXPECT_EQ(old.state, JobState::kSucceeded);
  EXPECT_EQ(old.folder, "captures/job-000001");
  EXPECT_EQ(old.frames_done, 4);
  EXPECT_EQ(old.request, nlohmann::json({{"kind", "single"}}));
  EXPECT_TRUE(*store_->finish(2, JobState::kDeviceLost,
                              make_error("device_lost", "camera unplugged"), nullptr));
  EXPECT_EQ((*store_->get(2))->state, JobState::kDeviceLost);
  // New jobs continue the old ids.
  EXPECT_EQ(store_->create("capture", "v4l2:old", {{"n", 1}}, "", 1)->id, 3);
  auto listed = store_->list(JobState::kDeviceLost, 10, 0);
  ASSERT_TRUE(listed.ok());
  EXPECT_EQ(listed->size(), 1u);
}

TEST_F(SqliteJobStoreTest, AFileThatIsNoDatabaseIsAnErrorValue) {
  const fs::path junk = folder_.path() / "junk.sqlite";
  {
    std::FILE* file = std::fopen(junk.c_str(), "wb");
    ASSERT_NE(file, nullptr);
    const std::string text(4096, 'j');
    std::fwrite(text.data(), 1, text.size(), file);
    std::fclose(file);
  }
  auto opened = JobStore::open(junk);
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.error().code, ErrorCode::kIoError);
  EXPECT_NE(opened.error().message.find("not a database"), std::string::npos)
      << opened.error().message;
}

}  // namespace
}  // namespace camlab::service
