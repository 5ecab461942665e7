// camlabd across restarts: a kill -9 during a capture leaves the job "interrupted" after
// the next start with its frames readable; SIGTERM during a capture exits 0 and
// interrupts the job cleanly; the token is created once and kept.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <map>

#include "daemon_harness.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

class ServiceLifecycle : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fresh_test_dir(std::string("lifecycle_") +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    write_test_specs(dir);
    args = {"--no-scan", "--camera-spec", (dir / "camera.json").string(), "--scene",
            (dir / "scene.json").string()};
  }
  void TearDown() override { fs::remove_all(dir); }

  // Starts a long capture and waits until it has written at least two frames.
  int64_t start_long_capture(Daemon& daemon) {
    const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
    auto r = daemon.post(camera + "/captures", {{"kind", "single"}, {"repeats", 100}});
    EXPECT_EQ(r.status, 202) << r.body;
    if (r.status != 202) return -1;
    const int64_t id = r.json()["id"];
    const json job = daemon.wait_job(
        id, [](const json& j) { return j["progress"]["frames_done"].get<int>() >= 2; });
    EXPECT_GE(job["progress"]["frames_done"].get<int>(), 2) << job.dump();
    return id;
  }

  fs::path dir;
  std::vector<std::string> args;
};

TEST_F(ServiceLifecycle, KillNineDuringAJobThenRestartLeavesItInterruptedWithFramesReadable) {
  Daemon first;
  ASSERT_TRUE(first.start(dir, args)) << first.log();
  const int64_t id = start_long_capture(first);
  ASSERT_GT(id, 0);
  EXPECT_EQ(first.stop(SIGKILL), 128 + SIGKILL);

  Daemon second;
  ASSERT_TRUE(second.start(dir, args)) << second.log();
  const json job = second.get("/v1/jobs/" + std::to_string(id)).json();
  EXPECT_EQ(job["state"], "interrupted") << job.dump();
  auto frames = second.get("/v1/jobs/" + std::to_string(id) + "/frames");
  ASSERT_EQ(frames.status, 200) << frames.body;
  const size_t count = frames.json()["frames"].size();
  EXPECT_GE(count, 2u);
  EXPECT_FALSE(frames.json()["complete"].get<bool>());
  for (size_t i = 0; i < count; ++i) {
    EXPECT_EQ(second.get("/v1/jobs/" + std::to_string(id) + "/frames/" + std::to_string(i)).status,
              200)
        << i;
    EXPECT_EQ(
        second.get("/v1/jobs/" + std::to_string(id) + "/frames/" + std::to_string(i) + "/meta")
            .status,
        200)
        << i;
  }
  // The database is consistent: the job list is readable and new jobs run.
  EXPECT_EQ(second.get("/v1/jobs?state=running").json()["jobs"].size(), 0u);
  auto next = second.post("/v1/cameras/" + url_segment(second.camera_id()) + "/captures",
                          {{"kind", "single"}});
  ASSERT_EQ(next.status, 202);
  EXPECT_EQ(second.wait_finished(next.json()["id"])["state"], "succeeded");
  EXPECT_EQ(second.stop(SIGTERM), 0) << second.log();
}

TEST_F(ServiceLifecycle, SigtermDuringAJobExitsZeroAndInterruptsTheJob) {
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, args)) << daemon.log();
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  const int64_t id = start_long_capture(daemon);
  ASSERT_GT(id, 0);
  auto queued = daemon.post(camera + "/captures", {{"kind", "single"}});
  ASSERT_EQ(queued.status, 202);
  EXPECT_EQ(daemon.stop(SIGTERM), 0) << daemon.log();
  EXPECT_NE(daemon.log().find("SIGTERM received"), std::string::npos);

  Daemon again;
  ASSERT_TRUE(again.start(dir, args)) << again.log();
  EXPECT_EQ(again.get("/v1/jobs/" + std::to_string(id)).json()["state"], "interrupted");
  EXPECT_EQ(
      again.get("/v1/jobs/" + std::to_string(queued.json()["id"].get<int64_t>())).json()["state"],
      "interrupted");
  EXPECT_EQ(again.get("/v1/jobs/" + std::to_string(id) + "/frames/0").status, 200);
  EXPECT_EQ(again.stop(SIGINT), 0);
}

// The token is created once and kept; it is never printed (a daemon's output lands in
// journals and CI logs): the first start names the file instead.
TEST_F(ServiceLifecycle, TheTokenIsCreatedOnceKeptAndNeverPrinted) {
  Daemon first;
  ASSERT_TRUE(first.start(dir, args)) << first.log();
  const std::string token = first.token();
  EXPECT_EQ(token.size(), 64u);
  EXPECT_EQ(first.log().find(token), std::string::npos) << "the token was printed";
  EXPECT_NE(first.log().find((dir / "data" / "token").string()), std::string::npos)
      << "the first start names the token's file:\n"
      << first.log();
  EXPECT_EQ(fs::status(dir / "data" / "token").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(first.stop(SIGTERM), 0);
  Daemon second;
  ASSERT_TRUE(second.start(dir, args)) << second.log();
  EXPECT_EQ(second.token(), token);
  EXPECT_EQ(second.log().find(token), std::string::npos) << "not printed again";
  EXPECT_EQ(http(second.port(), "GET", "/v1/cameras", token).status, 200);
  EXPECT_EQ(second.stop(SIGTERM), 0);
}

// The README's session typed line by line: GET .../frames right after the POST must
// answer 200 with the frames so far (none at first), never 404 while the job is queued or
// setting the camera up (the review got 404 during the first job's latency probe).
TEST_F(ServiceLifecycle, FramesOfAFreshJobAreAnEmptyListNotAnError) {
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, args)) << daemon.log();
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  auto r = daemon.post(
      camera + "/captures",
      {{"kind", "bracket"}, {"exposures_us", {1000, 2000, 4000, 8000}}, {"repeats", 2}});
  ASSERT_EQ(r.status, 202) << r.body;
  const std::string frames_path =
      "/v1/jobs/" + std::to_string(r.json()["id"].get<int64_t>()) + "/frames";
  size_t seen = 0;
  int polls = 0;
  for (; polls < 2000; ++polls) {  // bounded: 2000 x about 5 ms
    auto frames = daemon.get(frames_path);
    ASSERT_EQ(frames.status, 200) << "poll " << polls << ": " << frames.body;
    const size_t now = frames.json()["frames"].size();
    EXPECT_GE(now, seen) << "the frame list shrank";
    seen = now;
    if (frames.json()["complete"].get<bool>()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(seen, 8u) << "after " << polls << " polls";
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
}

// A loopback connection that sends `bytes` (maybe nothing, maybe half a request) and
// then holds the connection open without reading.
int hold_connection(int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return -1;
  if (!bytes.empty()) (void)::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  return fd;
}

// The review: 256 idle keep-alive or slow-header connections from one process made every
// other client, health checks included, get a reset for 15 s. Now the connection that
// has waited longest for a request gives way to a new one, and a client that finds every
// connection busy gets 503, never a reset.
TEST_F(ServiceLifecycle, HeldOpenConnectionsCannotLockOtherClientsOut) {
  std::vector<std::string> limited = args;
  limited.insert(limited.end(), {"--max-connections", "8"});
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, limited)) << daemon.log();
  std::vector<int> held;
  for (int i = 0; i < 8; ++i)  // half idle, half dribbling their headers
    held.push_back(hold_connection(
        daemon.port(), i % 2 ? "" : "GET /v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: "));
  for (int fd : held) ASSERT_GE(fd, 0);
  // Straight away nothing can give way (none has waited a second): an answer, not a reset.
  auto first = http(daemon.port(), "GET", "/v1/health");
  EXPECT_TRUE(first.status == 200 || first.status == 503) << "status " << first.status;
  if (first.status == 503) {
    EXPECT_EQ(first.error_code(), "too_many_connections");
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  for (int i = 0; i < 12; ++i) {  // more than the limit: each takes a held one's place
    auto r = http(daemon.port(), "GET", "/v1/health");
    EXPECT_EQ(r.status, 200) << "request " << i << ": " << r.body;
  }
  EXPECT_EQ(http(daemon.port(), "GET", "/v1/cameras", daemon.token()).status, 200);
  for (int fd : held) ::close(fd);
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
}

// The second review: 256 connections that pipelined requests for a public file and read
// none of the answers kept every new client at 503 for 35-41 s per round: a connection
// blocked writing was never evicted. Now, when full, the one blocked longest writing gives
// way (after a second), one address holds at most half the connections, and a connection
// answers at most 32 pipelined requests in a row.
TEST_F(ServiceLifecycle, SlowReadersCannotLockOtherClientsOut) {
  std::vector<std::string> limited = args;
  limited.insert(limited.end(), {"--max-connections", "32"});
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, limited)) << daemon.log();
  std::string pipelined;
  for (int i = 0; i < 2000; ++i) pipelined += "GET /ui/app.js HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  std::vector<int> readers;
  for (int i = 0; i < 32; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    ASSERT_GE(fd, 0);
    const int small = 4096;  // a reader that reads nothing fills up at once
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(daemon.port()));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    (void)::send(fd, pipelined.data(), pipelined.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    readers.push_back(fd);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  // For the next 3 s, a new client every 100 ms: each answered within the 2 s bound.
  int answered = 0, asked = 0;
  for (; asked < 30; ++asked) {
    auto r = http(daemon.port(), "GET", "/v1/health", "", "", std::chrono::seconds(2));
    EXPECT_EQ(r.status, 200) << "request " << asked << ": " << r.status << " " << r.body;
    answered += r.status == 200 ? 1 : 0;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::printf("%d of %d new clients answered among 32 connections that read nothing\n", answered,
              asked);
  for (int fd : readers) ::close(fd);
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
}

// The review's finding 1: requests the docs show failed on the default virtual camera
// (the focus stack 0..200 step 10 ended unstable_stream with 14 frames kept; a single
// capture of 100 frames kept 64-81). Both must keep every frame; frames the camera
// skips are the device's, never camlabd's.
TEST_F(ServiceLifecycle, TheDocumentedRequestsKeepEveryFrameOnTheDefaultVirtualCamera) {
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, {"--no-scan"})) << daemon.log();  // camlabd's own defaults
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  struct Case {
    json request;
    int frames;
  };
  for (const Case& c :
       {Case{{{"kind", "focus_stack"}, {"start", 0}, {"stop", 200}, {"step", 10}}, 21},
        Case{{{"kind", "single"}, {"repeats", 100}}, 100}}) {
    auto r = daemon.post(camera + "/captures", c.request);
    ASSERT_EQ(r.status, 202) << r.body;
    const json job = daemon.wait_finished(r.json()["id"]);
    EXPECT_EQ(job["state"], "succeeded") << c.request.dump() << ": " << job.dump();
    EXPECT_EQ(job["result"]["frames_kept"], c.frames) << job.dump();
    EXPECT_EQ(job["result"]["frames_dropped_by_camlabd"], 0) << job.dump();
  }
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
}

// The permission bits of every file in a capture job's folder.
std::map<std::string, fs::perms> folder_modes(const fs::path& data, Daemon& daemon) {
  const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  auto r = daemon.post(camera + "/captures", {{"kind", "single"}, {"repeats", 2}});
  EXPECT_EQ(r.status, 202) << r.body;
  if (r.status != 202) return {};
  const json job = daemon.wait_finished(r.json()["id"]);
  EXPECT_EQ(job["state"], "succeeded") << job.dump();
  std::map<std::string, fs::perms> modes;
  for (const auto& e : fs::directory_iterator(data / job["folder"].get<std::string>()))
    modes[e.path().filename().string()] = e.status().permissions() & fs::perms::all;
  return modes;
}

// The review found frames and sidecars 0644 whatever the umask. Now: 0666 less the umask
// by default, or exactly --file-mode; a mode that is not allowed stops the start with the
// rule.
TEST_F(ServiceLifecycle, CaptureFilesFollowTheUmaskOrFileMode) {
  const mode_t saved = ::umask(027);  // the daemon inherits it
  Daemon strict;
  const bool started = strict.start(dir, args);
  ::umask(saved);
  ASSERT_TRUE(started) << strict.log();
  auto modes = folder_modes(dir / "data", strict);
  ASSERT_GE(modes.size(), 5u);  // 2 frames, 2 sidecars, manifest, journal
  for (const auto& [name, mode] : modes)
    EXPECT_EQ(mode, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read)
        << name << " under umask 027";
  EXPECT_EQ(strict.stop(SIGTERM), 0);

  std::vector<std::string> with_mode = args;
  with_mode.insert(with_mode.end(), {"--file-mode", "0664"});
  Daemon chosen;
  ASSERT_TRUE(chosen.start(dir, with_mode)) << chosen.log();
  modes = folder_modes(dir / "data", chosen);
  ASSERT_GE(modes.size(), 5u);
  for (const auto& [name, mode] : modes)
    EXPECT_EQ(mode, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                        fs::perms::group_write | fs::perms::others_read)
        << name << " with --file-mode 0664";
  EXPECT_EQ(fs::status(dir / "data" / "token").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(chosen.stop(SIGTERM), 0);

  std::vector<std::string> bad_mode = args;
  bad_mode.insert(bad_mode.end(), {"--file-mode", "0755"});
  Daemon refused;
  EXPECT_FALSE(refused.start(dir, bad_mode));
  EXPECT_NE(refused.log().find("0600 .. 0666"), std::string::npos) << refused.log();
}

// The control latency is measured when a camera first opens, not inside the first capture
// (the review: the README's first capture took 12-16 s, the probe hidden in it). Without
// any job, the camera's latency appears in GET /v1/cameras; the first capture then probes
// nothing, and job ids start at 1 as the README's session expects.
TEST_F(ServiceLifecycle, ControlLatencyIsMeasuredAtStartUpNotInTheFirstCapture) {
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, args)) << daemon.log();
  json camera;
  for (int i = 0; i < 1200; ++i) {
    camera = daemon.get("/v1/cameras").json()["cameras"][0];
    if (!camera["control_latency"].is_null()) break;
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_FALSE(camera["control_latency"].is_null()) << camera.dump(1);
  // When it was measured, as a Unix time in ms (after 2020), under a name that says so.
  EXPECT_GT(camera["control_latency"].value("measured_at_unix_ms", int64_t{0}), 1577836800000)
      << camera.dump(1);
  EXPECT_FALSE(camera["measuring_latency"].get<bool>());
  EXPECT_TRUE(daemon.get("/v1/jobs").json()["jobs"].empty());
  auto r = daemon.post("/v1/cameras/" + url_segment(daemon.camera_id()) + "/captures",
                       {{"kind", "single"}});
  ASSERT_EQ(r.status, 202) << r.body;
  EXPECT_EQ(r.json()["id"], 1);
  const json job = daemon.wait_finished(1);
  ASSERT_EQ(job["state"], "succeeded") << job.dump(1);
  EXPECT_EQ(job["result"]["frames_consumed_by_probe"], 0);
  EXPECT_EQ(job["result"]["control_latency_frames"], camera["control_latency"]["frames"]);
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
}

}  // namespace

// A synchronised start that falls while the camera still measures its control latency at
// start-up fails late (`busy`), and says so: not "busy with an earlier job", which sent a
// user looking for a job that was never there.
TEST_F(ServiceLifecycle, ASynchronisedStartMissedWhileTheLatencyIsMeasuredSaysWhy) {
  Daemon daemon;
  ASSERT_TRUE(daemon.start(dir, args)) << daemon.log();
  const json camera = daemon.get("/v1/cameras").json()["cameras"][0];
  // The probe (36 frames) runs for about 0.6 s after camlabd listens (7 of 7 runs, 3 of
  // them beside two busy loops); were it over already, the start below would be met and
  // the case would show nothing: skipped, said, not passed.
  if (!camera.value("measuring_latency", false))
    GTEST_SKIP() << "the start-up latency probe ended before the first request";
  auto posted = daemon.post("/v1/sync-captures", {{"cameras", {camera["id"]}},
                                                  {"capture", {{"kind", "single"}}},
                                                  {"start_in_ms", 100},
                                                  {"max_late_ms", 0}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const json parent = daemon.wait_job(
      posted.json()["id"].get<int64_t>(),
      [](const json& j) { return j["state"] != "queued" && j["state"] != "running"; },
      std::chrono::seconds(60));
  ASSERT_EQ(parent["state"], "failed") << parent.dump(1);
  const json& error = parent["result"]["cameras"][0]["error"];
  EXPECT_EQ(error["code"], "busy") << parent.dump(1);
  const std::string message = error.value("message", std::string());
  EXPECT_NE(message.find("after the start with measuring its control latency at start-up"),
            std::string::npos)
      << message;
  EXPECT_EQ(message.find("earlier job"), std::string::npos) << message;
  std::printf("late start: %s\n", message.c_str());
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
}
