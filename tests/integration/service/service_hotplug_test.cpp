// Hot-plug: cameras that vanish and come back while camlabd runs. An in-process virtual
// camera is unplugged (test fault API) during a 100-frame capture: the job ends
// device_lost with the frames captured so far readable and its manifest kept, the camera
// is listed as gone and refuses work; replugged, it is served again under the same id and
// a new job succeeds, all without camlabd restarting. Under `camlab vcam run` the same is
// done through the broker (`camlab vcam fault`), where /dev makes no inotify events and
// the periodic rescan is what notices.
//
// The times from unplug to device_lost and from replug to available are printed (they are
// figures, not pass criteria: timing is measured, never asserted).
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <sstream>
#include <string>

#include "capture_checks.h"
#include "vcam_launch.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Polls GET /v1/cameras until camera `id`'s summary satisfies `done` (bounded).
template <class Pred>
json wait_camera(const Daemon& daemon, const std::string& id, Pred done,
                 std::chrono::seconds timeout = 15s) {
  json found;
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    const json list = daemon.get("/v1/cameras").json();
    if (list.is_object())
      for (const auto& c : list["cameras"])
        if (c.value("id", "") == id) found = c;
    if (!found.is_null() && done(found)) return found;
    std::this_thread::sleep_for(20ms);
  }
  return found;
}

// The checks every lost job must pass: device_lost with the reason, fewer than the 100
// frames asked, every frame written readable through the API with its sidecar, and the
// folder on disk an incomplete capture whose journal lists exactly those frames.
void check_lost_job(const Daemon& daemon, const fs::path& data, const json& job) {
  EXPECT_EQ(job["state"], "device_lost") << job.dump();
  EXPECT_EQ(job["error"]["code"], "device_lost") << job.dump();
  EXPECT_NE(job["error"]["message"].get<std::string>().find("unplugged"), std::string::npos)
      << job.dump();
  const int done = job["progress"]["frames_done"].get<int>();
  EXPECT_GE(done, 5) << job.dump();
  EXPECT_LT(done, 100) << job.dump();
  const int64_t id = job["id"];
  const json frames = daemon.get("/v1/jobs/" + std::to_string(id) + "/frames").json();
  EXPECT_EQ(frames["complete"], false);
  ASSERT_EQ(frames["frames"].size(), static_cast<size_t>(done)) << frames.dump();
  uint64_t last_sequence = 0;
  for (int i = 0; i < done; ++i) {
    const DownloadedFrame frame = download_frame(daemon, id, i);
    ASSERT_FALSE(frame.image.empty()) << "frame " << i;
    EXPECT_EQ(frame.image.cols, 160);
    const uint64_t sequence = frame.sidecar["sequence"];
    if (i > 0) {
      EXPECT_GT(sequence, last_sequence) << "frame " << i;
    }
    last_sequence = sequence;
  }
  const fs::path folder = data / job["folder"].get<std::string>();
  const json manifest = json::parse(read_file(folder / "manifest.json"));
  EXPECT_EQ(manifest["complete"], false);
  // The folder's frames journal (docs/capture-folder.md, version 3) lists exactly those.
  size_t listed = 0;
  std::istringstream journal(read_file(folder / "frames.jsonl"));
  for (std::string line; std::getline(journal, line);)
    if (!line.empty()) ++listed;
  EXPECT_EQ(listed, static_cast<size_t>(done));
}

bool alive(pid_t pid) { return pid > 0 && ::kill(pid, 0) == 0; }

class ServiceHotplug : public SharedDaemonSuite<ServiceHotplug> {
 protected:
  static void SetUpTestSuite() {
    start_shared_daemon("hotplug", [](const fs::path& dir) {
      return Launch{{"--no-scan", "--camera-spec", (dir / "camera.json").string(), "--scene",
                     (dir / "scene.json").string(), "--test-faults", "--frame-timeout-ms", "3000"},
                    {}};
    });
  }
  void fault(const json& body) {
    ASSERT_EQ(
        daemon_->post("/v1/test/cameras/" + url_segment(daemon_->camera_id()) + "/faults", body)
            .status,
        200);
  }
};

TEST_F(ServiceHotplug, UnplugEndsTheJobDeviceLostAndReplugServesTheSameIdAgain) {
  const std::string id = daemon_->camera_id();
  const pid_t pid = daemon_->pid();
  auto r = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 100}});
  ASSERT_EQ(r.status, 202) << r.body;
  const int64_t job_id = r.json()["id"];
  daemon_->wait_job(job_id, [](const json& j) { return j["progress"]["frames_done"] >= 5; });

  const auto unplugged_at = Clock::now();
  fault({{"unplug", true}});
  const json job = daemon_->wait_finished(job_id, 30s);
  const double lost_ms = ms_since(unplugged_at);
  check_lost_job(*daemon_, *dir_ / "data", job);

  // Gone: listed, not present, and refusing work with no_device.
  const json gone = wait_camera(*daemon_, id, [](const json& c) { return !c["present"]; });
  EXPECT_EQ(gone["present"], false) << gone.dump();
  EXPECT_EQ(gone["available"], false) << gone.dump();
  auto refused = daemon_->post(camera_ + "/captures", {{"kind", "single"}});
  EXPECT_EQ(refused.status, 503) << refused.body;
  EXPECT_EQ(refused.error_code(), "no_device") << refused.body;

  const auto replugged_at = Clock::now();
  fault({{"replug", true}});
  const json back = wait_camera(*daemon_, id, [](const json& c) {
    return c["present"].get<bool>() && c["available"].get<bool>();
  });
  const double back_ms = ms_since(replugged_at);
  ASSERT_EQ(back["available"], true) << back.dump() << daemon_->log();
  std::printf(
      "[ figures  ] in-process: unplug -> job device_lost %.0f ms; replug -> available "
      "%.0f ms\n",
      lost_ms, back_ms);

  // Under the same id, a new job succeeds with every frame; camlabd never restarted.
  auto again = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 3}});
  ASSERT_EQ(again.status, 202) << again.body;
  const json next = daemon_->wait_finished(again.json()["id"]);
  EXPECT_EQ(next["state"], "succeeded") << next.dump();
  EXPECT_EQ(next["progress"]["frames_done"], 3);
  EXPECT_EQ(daemon_->pid(), pid);
  EXPECT_TRUE(alive(pid));
  EXPECT_EQ(daemon_->camera_id(), id);
}

TEST_F(ServiceHotplug, AJobQueuedBehindTheLostOneEndsDeviceLostWithoutFrames) {
  auto first = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 100}});
  auto second = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 2}});
  ASSERT_EQ(first.status, 202) << first.body;
  ASSERT_EQ(second.status, 202) << second.body;
  daemon_->wait_job(first.json()["id"],
                    [](const json& j) { return j["progress"]["frames_done"] >= 5; });
  fault({{"unplug", true}});
  check_lost_job(*daemon_, *dir_ / "data", daemon_->wait_finished(first.json()["id"], 30s));
  const json queued = daemon_->wait_finished(second.json()["id"], 30s);
  EXPECT_EQ(queued["state"], "device_lost") << queued.dump();
  EXPECT_EQ(queued["progress"]["frames_done"], 0) << queued.dump();
  // It either never started (the rescan retired the camera first) or found it gone.
  EXPECT_TRUE(queued["result"].is_null()) << queued.dump();
  fault({{"replug", true}});
  const json back = wait_camera(*daemon_, daemon_->camera_id(),
                                [](const json& c) { return c["available"].get<bool>(); });
  EXPECT_EQ(back["available"], true) << back.dump();
}

// The broker path: camlabd under `camlab vcam run` sees the camera as a kernel device;
// the fault goes through the broker as `camlab vcam fault` sends it, and only the
// periodic rescan (the preload's /dev makes no inotify events) notices.
class ServiceHotplugVcam : public SharedDaemonSuite<ServiceHotplugVcam> {
 protected:
  static void SetUpTestSuite() {
    start_shared_daemon("hotplug_vcam", [](const fs::path& dir) {
      const std::string camera = (dir / "camera.json").string();
      return Launch{{"--no-virtual", "--no-libcamera", "--device", "/dev/video0", "--device-spec",
                     camera, "--frame-timeout-ms", "3000"},
                    vcam_prefix_saving_broker(dir, camera, (dir / "scene.json").string())};
    });
  }
  static void fault(const std::string& name) {
    const CliRun run = run_cli_with_broker(*dir_, "vcam fault " + name);
    ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  }
};

TEST_F(ServiceHotplugVcam, UnplugAndReplugThroughTheBrokerAreNoticedByTheRescan) {
  const std::string id = daemon_->camera_id();
  ASSERT_FALSE(id.empty());
  const pid_t pid = daemon_->pid();
  auto r = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 100}});
  ASSERT_EQ(r.status, 202) << r.body;
  const int64_t job_id = r.json()["id"];
  daemon_->wait_job(job_id, [](const json& j) { return j["progress"]["frames_done"] >= 5; });

  const auto unplugged_at = Clock::now();
  fault("unplug");
  const json job = daemon_->wait_finished(job_id, 30s);
  const double lost_ms = ms_since(unplugged_at);
  check_lost_job(*daemon_, *dir_ / "data", job);
  const json gone = wait_camera(*daemon_, id, [](const json& c) { return !c["present"]; });
  EXPECT_EQ(gone["present"], false) << gone.dump() << daemon_->log();

  const auto replugged_at = Clock::now();
  fault("replug");
  const json back = wait_camera(*daemon_, id, [](const json& c) {
    return c["present"].get<bool>() && c["available"].get<bool>();
  });
  const double back_ms = ms_since(replugged_at);
  ASSERT_EQ(back["available"], true) << back.dump() << daemon_->log();
  std::printf(
      "[ figures  ] vcam run: unplug -> job device_lost %.0f ms; replug -> available "
      "%.0f ms (rescan every 1000 ms)\n",
      lost_ms, back_ms);

  auto again = daemon_->post(camera_ + "/captures", {{"kind", "single"}, {"repeats", 3}});
  ASSERT_EQ(again.status, 202) << again.body;
  const json next = daemon_->wait_finished(again.json()["id"]);
  EXPECT_EQ(next["state"], "succeeded") << next.dump();
  EXPECT_EQ(daemon_->pid(), pid);
  EXPECT_TRUE(alive(pid));
}

}  // namespace
