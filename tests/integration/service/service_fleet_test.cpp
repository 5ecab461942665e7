// camlabd hosts in a fleet on one machine (tests/integration/service/fleet_harness.h): a
// throwaway PostgreSQL cluster and three hosts with two virtual cameras each.
//
// - 200 captures submitted through random hosts for random cameras, while one host is
//   killed with SIGKILL and PostgreSQL restarts: every job ends exactly once (its history
//   in job_events holds one final state, and ran at most once), only the killed host's
//   jobs are interrupted, and every frame recorded downloads whole through any host.
// - A synchronised capture over the six cameras reports each frame's start, none before
//   the common start, with the skew worked out from those starts.
// - A host cut off from the database stops its capture, the fleet interrupts the job once,
//   and the host joins again and captures.
//
// Skipped, saying why, only when PostgreSQL's server binaries are not installed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>
#include <thread>

#include "fleet_harness.h"
#include "tests/support/job_history.h"
#include "tests/support/tcp_proxy.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

// The test camera at 10 ms frames: captures are short, so 200 of them fit in seconds.
std::string fast_camera_spec() {
  json camera = json::parse(kTestCameraSpec);
  camera["name"] = "camlabd fleet test camera 160x120";
  camera["timing"]["frame_interval_us"] = 10000;
  camera["controls"]["exposure_time_absolute"]["max"] = 100;
  return camera.dump();
}

bool finished(const json& job) {
  const std::string state = job.value("state", "");
  return !state.empty() && state != "queued" && state != "running";
}

class ServiceFleet : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string missing = PgCluster::missing(); !missing.empty()) GTEST_SKIP() << missing;
    dir_ = fresh_test_dir("fleet");
    fleet_ = std::make_unique<FleetHarness>(dir_, fast_camera_spec());
    std::string error;
    ASSERT_TRUE(fleet_->start_database(&error)) << error;
  }
  void TearDown() override {
    if (HasFailure() && fleet_) std::printf("%s\n", fleet_->logs().c_str());
    fleet_.reset();
    fs::remove_all(dir_);
  }

  // Each job's states in the order its history (job_events) holds them.
  std::map<int64_t, std::vector<std::string>> history() {
    bool ok = false;
    auto states = job_histories(fleet_->cluster(), "camlab", &ok);
    EXPECT_TRUE(ok);
    return states;
  }

  // Every frame job `id` lists, fetched through `via` (redirected to its host), decodes
  // and says its index; returns how many it lists.
  int check_frames(const Daemon& via, const json& job) {
    const std::string base = "/v1/jobs/" + std::to_string(job["id"].get<int64_t>());
    auto listing = fleet_->get_following(via, base + "/frames");
    if (listing.status == 404) return 0;  // never began: no folder
    EXPECT_EQ(listing.status, 200) << base << ": " << listing.body;
    const json frames = listing.json()["frames"];
    for (size_t i = 0; i < frames.size(); ++i) {
      auto png = fleet_->get_following(via, base + "/frames/" + std::to_string(i));
      EXPECT_EQ(png.status, 200) << base << " frame " << i;
      const cv::Mat image =
          cv::imdecode(std::vector<uchar>(png.body.begin(), png.body.end()), cv::IMREAD_UNCHANGED);
      EXPECT_EQ(image.size(), cv::Size(160, 120)) << base << " frame " << i;
      const json meta =
          fleet_->get_following(via, base + "/frames/" + std::to_string(i) + "/meta").json();
      EXPECT_EQ(meta.value("index", -1), static_cast<int>(i)) << base;
    }
    return static_cast<int>(frames.size());
  }

  fs::path dir_;
  std::unique_ptr<FleetHarness> fleet_;
};

TEST_F(ServiceFleet, TwoHundredJobsEndOnceThroughAKilledHostAndADatabaseRestart) {
  const std::vector<std::string> names = {"host-0", "host-1", "host-2"};
  // A lease of 4 s: a host that died is found within seconds, and a database restart
  // (well under a second here) is waited out without fencing anyone.
  for (const auto& name : names) ASSERT_NE(fleet_->start_host(name, 4000), nullptr) << name;
  const json ready = fleet_->wait_live(*fleet_->host("host-0"), 3);
  ASSERT_TRUE(ready.is_object()) << fleet_->host("host-0")->log();
  const std::vector<std::string> cameras = FleetHarness::camera_ids(ready);
  ASSERT_EQ(cameras.size(), 6u);

  std::mt19937 rng(17);
  std::set<std::string> alive(names.begin(), names.end());
  std::map<int64_t, std::string> accepted;  // job -> the camera's host
  int refused_gone = 0, retried = 0;
  const auto started = std::chrono::steady_clock::now();
  for (int i = 0; i < 200; ++i) {
    if (i == 50) {  // mid-run: host-1 dies without a word
      EXPECT_EQ(fleet_->host("host-1")->stop(SIGKILL), 128 + SIGKILL);
      alive.erase("host-1");
    }
    if (i == 150) {  // and PostgreSQL restarts under the fleet
      EXPECT_TRUE(fleet_->cluster().restart()) << fleet_->cluster().server_log();
    }
    const std::string camera = cameras[rng() % cameras.size()];
    const std::string camera_host = camera.substr(camera.rfind('@') + 1);
    const json request = {{"kind", "single"}, {"repeats", 1 + static_cast<int>(rng() % 3)}};
    bool done = false;
    for (int attempt = 0; attempt < 300 && !done; ++attempt) {
      std::vector<std::string> via(alive.begin(), alive.end());
      const Daemon& api = *fleet_->host(via[rng() % via.size()]);
      auto r = api.post("/v1/cameras/" + url_segment(camera) + "/captures", request);
      if (r.status == 202) {
        accepted[r.json()["id"].get<int64_t>()] = camera_host;
        done = true;
      } else if (r.error_code() == "host_unavailable" || r.error_code() == "no_device") {
        EXPECT_FALSE(alive.count(camera_host)) << r.body;  // only the dead host's cameras
        ++refused_gone;
        done = true;
      } else if (r.status == 0 || r.error_code() == "database_unavailable" ||
                 r.error_code() == "too_many_jobs") {
        ++retried;  // the database restarting, a full queue: try again shortly
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      } else {
        ADD_FAILURE() << "submission " << i << ": " << r.status << " " << r.body;
        done = true;
      }
    }
    EXPECT_TRUE(done) << "submission " << i << " never got an answer";
    // 200 submissions over about 10 s: the dead host's lease (4 s) passes mid-run, so its
    // cameras' jobs are first accepted (and ended by the fleet), then refused.
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  // The killed host comes back: the frames it captured are served again.
  ASSERT_NE(fleet_->start_host("host-1", 4000), nullptr);
  alive.insert("host-1");
  ASSERT_TRUE(fleet_->wait_live(*fleet_->host("host-0"), 3).is_object());

  std::map<int64_t, json> jobs;
  for (const auto& [id, host] : accepted) {
    const json job = fleet_->host("host-2")->wait_job(id, finished, std::chrono::seconds(60));
    ASSERT_TRUE(finished(job)) << id << ": " << job.dump();
    jobs[id] = job;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  // Exactly once: one final state per job in its history, and at most one run.
  const auto states = history();
  int interrupted = 0, frames = 0;
  for (const auto& [id, job] : jobs) {
    SCOPED_TRACE("job " + std::to_string(id) + " " + job.dump());
    const auto& h = states.at(id);
    EXPECT_EQ(std::count_if(h.begin(), h.end(),
                            [](const std::string& s) { return s != "queued" && s != "running"; }),
              1);
    EXPECT_LE(std::count(h.begin(), h.end(), "running"), 1);
    EXPECT_EQ(h.back(), job["state"]);
    EXPECT_EQ(job["host"], accepted[id]);
    if (job["state"] == "interrupted") {
      EXPECT_EQ(accepted[id], "host-1") << "only the killed host's jobs are interrupted";
      ++interrupted;
    } else {
      EXPECT_EQ(job["state"], "succeeded");
    }
    // Every frame recorded is there and whole, through any host.
    const int listed = check_frames(*fleet_->host(names[id % names.size()]), job);
    EXPECT_GE(listed, job["progress"]["frames_done"].get<int>());
    frames += listed;
    // Run once: its folder is on its own host only.
    for (const auto& name : names) {
      if (name == accepted[id]) continue;
      EXPECT_FALSE(fs::exists(dir_ / name / "data" / job.value("folder", "none"))) << name;
    }
  }
  // Every job the database holds ended (a submission retried during the restart may have
  // been stored once before its answer was lost: it ran like the rest).
  bool ok = false;
  EXPECT_EQ(fleet_->cluster().sql(
                "camlab", "SELECT count(*) FROM jobs WHERE state IN ('queued', 'running')", &ok),
            "0\n");
  std::printf(
      "fleet run: %zu jobs accepted (%d refused: camera's host dead, %d retries), %d "
      "interrupted with host-1, %d frames read back, %.1f s\n",
      accepted.size(), refused_gone, retried, interrupted, frames, seconds);
}

TEST_F(ServiceFleet, ASynchronisedCaptureReportsEachFramesStartOnEveryHost) {
  for (const char* name : {"host-0", "host-1", "host-2"})
    ASSERT_NE(fleet_->start_host(name, 3000), nullptr) << name;
  const json ready = fleet_->wait_live(*fleet_->host("host-0"), 3);
  ASSERT_TRUE(ready.is_object());
  const std::vector<std::string> cameras = FleetHarness::camera_ids(ready);
  ASSERT_EQ(cameras.size(), 6u);
  const Daemon& api = *fleet_->host("host-1");
  auto posted = api.post("/v1/sync-captures", {{"cameras", cameras},
                                               {"capture", {{"kind", "single"}, {"repeats", 5}}},
                                               {"start_in_ms", 1500}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const int64_t id = posted.json()["id"];
  const json job = api.wait_job(id, finished, std::chrono::seconds(60));
  ASSERT_EQ(job["state"], "succeeded") << job.dump(1);
  const json& result = job["result"];
  const int64_t start_us = result["start_at_unix_ms"].get<int64_t>() * 1000;
  ASSERT_EQ(result["cameras"].size(), cameras.size());
  for (const json& camera : result["cameras"]) {
    SCOPED_TRACE(camera.dump());
    ASSERT_EQ(camera["frames"].size(), 5u);
    const json child = api.get("/v1/jobs/" + std::to_string(camera["job"].get<int64_t>())).json();
    EXPECT_EQ(child["host"], camera["host"]);
    for (size_t k = 0; k < 5; ++k) {
      const json& frame = camera["frames"][k];
      const int64_t at = frame["start_unix_us"].get<int64_t>();
      EXPECT_GE(at, start_us) << "a frame began before the common start";
      // The frame reported is the frame stored: its sidecar (on its host) has its sequence.
      const json meta =
          fleet_
              ->get_following(api, "/v1/jobs/" + std::to_string(camera["job"].get<int64_t>()) +
                                       "/frames/" + std::to_string(k) + "/meta")
              .json();
      EXPECT_EQ(meta["sequence"], frame["sequence"]);
    }
  }
  // Each trigger's skew is its rig view's: the latest minus the earliest start of its frames.
  // These six cameras run on six free clocks, so a frame can fall half an interval from
  // every other camera's and make a view of its own: such a view has no skew (null).
  int64_t worst = 0;
  size_t frames_in_views = 0, views_with_skew = 0;
  const json& views = result["rig_views"]["views"];
  ASSERT_EQ(result["skew_us"]["per_view"].size(), views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    std::vector<int64_t> at;
    for (size_t c = 0; c < views[v]["frames"].size(); ++c) {
      if (!views[v]["frames"][c].is_number_integer()) continue;
      // The view names a frame by its index in the camera's capture folder.
      for (const json& frame : result["cameras"][c]["frames"])
        if (frame["index"] == views[v]["frames"][c])
          at.push_back(frame["start_unix_us"].get<int64_t>());
    }
    ASSERT_FALSE(at.empty()) << "view " << v << " names no frame of the capture";
    frames_in_views += at.size();
    if (at.size() == 1) {
      EXPECT_TRUE(result["skew_us"]["per_view"][v].is_null()) << "view " << v;
      continue;
    }
    ++views_with_skew;
    const auto [low, high] = std::minmax_element(at.begin(), at.end());
    EXPECT_EQ(result["skew_us"]["per_view"][v], *high - *low) << "view " << v;
    worst = std::max(worst, *high - *low);
  }
  // Every frame is in exactly one view, and the triggers' frames met in some.
  EXPECT_EQ(frames_in_views, 5 * cameras.size());
  ASSERT_GT(views_with_skew, 0u);
  EXPECT_EQ(result["skew_us"]["max"], worst);
  // One machine, one clock: each host's measured offset lies within its uncertainty.
  ASSERT_EQ(result["host_clocks"].size(), 3u);
  for (const json& clock : result["host_clocks"])
    EXPECT_LE(std::abs(clock["offset_to_database_us"].get<int64_t>()),
              clock["uncertainty_us"].get<int64_t>() + 2)
        << clock.dump();
  std::printf(
      "synchronised capture: 6 cameras on 3 hosts, %zu rig views (%zu of one camera), skew "
      "%lld us at most (frame interval %lld us)\n",
      views.size(), views.size() - views_with_skew, static_cast<long long>(worst),
      static_cast<long long>(result["frame_interval_us"].get<int64_t>()));
  // Cancelled through a host other than the one that took it: that host knew only its own
  // synchronised captures, answered 202 and cancelled nothing; it reads the captures from
  // the record now, and the host that took it ends it once they have ended.
  auto longer = api.post("/v1/sync-captures", {{"cameras", cameras},
                                               {"capture", {{"kind", "single"}, {"repeats", 2000}}},
                                               {"start_in_ms", 500}});
  ASSERT_EQ(longer.status, 202) << longer.body;
  const int64_t longer_id = longer.json()["id"];
  const json capturing = api.wait_job(longer_id, [](const json& j) {
    return finished(j) || j["progress"]["frames_done"].get<int>() > 0;
  });
  ASSERT_EQ(capturing["state"], "running") << capturing.dump(1).substr(0, 2000);
  auto cancel = fleet_->host("host-2")->del("/v1/jobs/" + std::to_string(longer_id));
  ASSERT_EQ(cancel.status, 202) << cancel.body;
  const json ended = api.wait_job(longer_id, finished, std::chrono::seconds(60));
  EXPECT_EQ(ended["state"], "failed") << ended.dump(1).substr(0, 2000);
  for (const json& child : ended["request"]["jobs"])
    EXPECT_EQ(api.get("/v1/jobs/" + std::to_string(child.get<int64_t>())).json()["state"],
              "cancelled");
}

// A rig of three cameras on one host, on one frame clock, the third triggered 2.5 ms after
// the others: the synchronised capture groups their frames into rig views by start time;
// the first two cameras' frames start within 1 ms of each other, and every view with the
// third is flagged over the 1 ms bound.
TEST_F(ServiceFleet, ARigCaptureReportsEachRigViewsSkewOnOneHost) {
  const fs::path rig = dir_ / "rig.json";
  const std::string camera = (dir_ / "camera.json").string();
  std::ofstream(rig) << json{{"scene", (dir_ / "scene.json").string()},
                             {"cameras",
                              {{{"camera", camera}, {"rt_cam_ref", {0, 0, 0, 0, 0, 0}}},
                               {{"camera", camera}, {"rt_cam_ref", {0, 0, 0, -0.1, 0, 0}}},
                               {{"camera", camera},
                                {"rt_cam_ref", {0, 0.2, 0, -0.2, 0, 0}},
                                {"trigger_offset_us", 2500}}}}}
                            .dump();
  ASSERT_NE(fleet_->start_host("host-0", 3000, "", {"--rig", rig.string()}), nullptr);
  const json ready =
      fleet_->wait_live(*fleet_->host("host-0"), 1, std::chrono::seconds(60), /*cameras_each=*/3);
  ASSERT_TRUE(ready.is_object());
  const std::vector<std::string> cameras = FleetHarness::camera_ids(ready);
  ASSERT_EQ(cameras.size(), 3u);
  const Daemon& api = *fleet_->host("host-0");
  auto posted = api.post("/v1/sync-captures", {{"cameras", cameras},
                                               {"capture", {{"kind", "single"}, {"repeats", 6}}},
                                               {"start_in_ms", 1000},
                                               {"max_skew_us", 1000}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const json job = api.wait_job(posted.json()["id"], finished, std::chrono::seconds(60));
  ASSERT_EQ(job["state"], "succeeded") << job.dump(1);
  const json& result = job["result"];
  const json& views = result["rig_views"];
  ASSERT_TRUE(views.is_object()) << result.dump(1);
  EXPECT_EQ(views["max_skew_us"], 1000);
  EXPECT_GE(views["complete"].get<int>(), 3) << views.dump(1);
  int pairs = 0;
  int64_t worst_pair_us = 0;
  for (const json& view : views["views"]) {
    const json& f = view["frames"];
    auto start = [&](int c) {
      return result["cameras"][c]["frames"][f[c].get<int>()]["start_unix_us"].get<int64_t>();
    };
    if (!f[0].is_null() && !f[1].is_null()) {
      EXPECT_LE(std::abs(start(1) - start(0)), 1000) << view.dump();
      worst_pair_us = std::max(worst_pair_us, std::abs(start(1) - start(0)));
      ++pairs;
    }
    if (!f[2].is_null() && !f[0].is_null()) {
      EXPECT_NEAR(static_cast<double>(start(2) - start(0)), 2500, 1000) << view.dump();
      EXPECT_FALSE(view["within_bound"].get<bool>()) << view.dump();
    }
  }
  EXPECT_GE(pairs, 3);
  EXPECT_EQ(views["over_bound"], views["complete"]);
  std::printf(
      "rig capture: 3 cameras, %d complete rig views of %zu, worst skew %lld us (cameras 0 and "
      "1, one trigger: %lld us)\n",
      views["complete"].get<int>(), views["views"].size(),
      static_cast<long long>(views["worst_skew_us"].get<int64_t>()),
      static_cast<long long>(worst_pair_us));
}

// A stereo rig from capture to calibration: two cameras 100 mm apart (the wide lens binned
// to 640x400), the board moving through the example set's poses on the rig's clock (a pose
// a frame); one synchronised capture, then POST /v1/calibrations {"rig_capture"}
// pairs the frames by its rig views and finds the baseline.
TEST_F(ServiceFleet, ARigCaptureCalibratesIntoTheRigsBaseline) {
  json camera = json::parse(
      std::ifstream(CAMLAB_SOURCE_DIR "/mock_device/examples/camera_wide_1280x800.json"));
  camera["sensor"]["width_px"] = 640;
  camera["sensor"]["height_px"] = 400;
  camera["sensor"]["pixel_pitch_um"] = 6.0;
  camera["lens"]["principal_point_px"] = {321.15, 199.05};
  camera["timing"]["frame_interval_us"] = 100000;  // 10 frames/s: rendered in time on 2 cores
  const fs::path rig = dir_ / "stereo.json";
  std::ofstream(rig) << json{{"scene", CAMLAB_SOURCE_DIR
                              "/mock_device/examples/scene_chessboard_calibration.json"},
                             {"view_every_frames", 1},
                             {"cameras",
                              {{{"camera", camera}, {"rt_cam_ref", {0, 0, 0, 0, 0, 0}}},
                               {{"camera", camera}, {"rt_cam_ref", {0, 0, 0, -0.1, 0, 0}}}}}}
                            .dump();
  ASSERT_NE(fleet_->start_host("host-0", 3000, "", {"--rig", rig.string()}), nullptr);
  // A second host, to cancel host-0's calibration from.
  ASSERT_NE(fleet_->start_host("host-1", 3000), nullptr);
  const json ready =
      fleet_->wait_live(*fleet_->host("host-0"), 2, std::chrono::seconds(90), /*cameras_each=*/2);
  ASSERT_TRUE(ready.is_object());
  std::vector<std::string> cameras;
  for (const std::string& id : FleetHarness::camera_ids(ready))
    if (id.ends_with("@host-0")) cameras.push_back(id);
  ASSERT_EQ(cameras.size(), 2u);
  const Daemon& api = *fleet_->host("host-0");
  auto posted = api.post("/v1/sync-captures", {{"cameras", cameras},
                                               {"capture", {{"kind", "single"}, {"repeats", 12}}},
                                               {"start_in_ms", 1000}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const int64_t capture = posted.json()["id"];
  const json captured = api.wait_job(capture, finished, std::chrono::seconds(120));
  ASSERT_EQ(captured["state"], "succeeded") << captured.dump(1);
  const json& views = captured["result"]["rig_views"];
  EXPECT_GE(views["complete"].get<int>(), 8) << views.dump(1);
  EXPECT_EQ(views["over_bound"], 0) << views.dump(1);
  // Not a capture of one camera, and not a running one: refused with the reason.
  EXPECT_EQ(api.post("/v1/calibrations", {{"rig_capture", capture}, {"job", 1}}).status, 400);
  const json board = {{"rig_capture", capture},
                      {"inner_corners", {14, 10}},
                      {"spacing_m", 0.04},
                      {"model", "LENSMODEL_OPENCV8"}};
  auto calibration = api.post("/v1/calibrations", board);
  ASSERT_EQ(calibration.status, 202) << calibration.body;
  // A second one waits in the compute queue, queued in the fleet's database, through the
  // dispatcher's polls (every 500 ms) while the first computes: it is no camera's job and
  // must not be ended as one ("camera  is not on host": device_lost, before the fix).
  auto repeated = api.post("/v1/calibrations", board);
  ASSERT_EQ(repeated.status, 202) << repeated.body;
  const json job = api.wait_job(calibration.json()["id"], finished, std::chrono::seconds(300));
  ASSERT_EQ(job["state"], "succeeded") << job.dump(1).substr(0, 3000);
  const json repeat = api.wait_job(repeated.json()["id"], finished, std::chrono::seconds(300));
  ASSERT_EQ(repeat["state"], "succeeded") << repeat.dump(1).substr(0, 3000);
  EXPECT_NEAR(repeat["result"]["report"]["cameras"][1]["baseline_m"].get<double>(),
              job["result"]["report"]["cameras"][1]["baseline_m"].get<double>(), 1e-9);
  EXPECT_EQ(job["result"]["rig_views_left_out"]["over_bound"], 0);
  const json& report = job["result"]["report"];
  const json baseline_m = report["cameras"][1]["baseline_m"];
  ASSERT_TRUE(baseline_m.is_number()) << report.dump(1).substr(0, 3000);
  const double baseline_mm = 1000 * baseline_m.get<double>();
  const double sigma_mm = report["cameras"][1]["baseline_sigma_mm"].get<double>();
  std::printf("rig capture -> calibration: %d rig views, baseline %.3f +- %.3f mm (truth 100)\n",
              views["complete"].get<int>(), baseline_mm, sigma_mm);
  EXPECT_NEAR(baseline_mm, 100.0, std::max(0.5, 4 * sigma_mm));
  // Cancelled from another host while it runs: the cancel request reaches host-0's compute
  // worker through the database (it reached only camera workers, and the job ran on).
  auto third = api.post("/v1/calibrations", board);
  ASSERT_EQ(third.status, 202) << third.body;
  const int64_t third_id = third.json()["id"];
  const json running = api.wait_job(third_id, [](const json& j) { return j["state"] != "queued"; });
  ASSERT_EQ(running["state"], "running") << running.dump(1).substr(0, 2000);
  auto cancel = fleet_->host("host-1")->del("/v1/jobs/" + std::to_string(third_id));
  ASSERT_EQ(cancel.status, 202) << cancel.body;
  EXPECT_TRUE(cancel.json()["cancel_requested"].get<bool>());
  const json cancelled = api.wait_job(third_id, finished, std::chrono::seconds(60));
  EXPECT_EQ(cancelled["state"], "cancelled") << cancelled.dump(1).substr(0, 2000);
  // A calibration session's job is no worker's to stop (its own endpoints end it): through
  // either host the DELETE says so, where another host answered 202 and nothing acted.
  const std::string local_camera = cameras[0].substr(0, cameras[0].rfind('@'));
  auto session = api.post("/v1/calibration-sessions", {{"camera", local_camera},
                                                       {"inner_corners", {14, 10}},
                                                       {"spacing_m", 0.04},
                                                       {"model", "LENSMODEL_OPENCV8"}});
  ASSERT_EQ(session.status, 201) << session.body;
  const std::string session_job = "/v1/jobs/" + std::to_string(session.json()["id"].get<int64_t>());
  auto here = api.del(session_job);
  auto there = fleet_->host("host-1")->del(session_job);
  EXPECT_EQ(here.status, 409) << here.body;
  EXPECT_EQ(there.status, 409) << there.body;
  EXPECT_EQ(there.json()["error"]["code"], here.json()["error"]["code"]) << there.body;
  EXPECT_EQ(
      api.del("/v1/calibration-sessions/" + std::to_string(session.json()["id"].get<int64_t>()))
          .status,
      200);
}

// Cloned hosts (the review's finding 2): two camlabd with one --host-name fenced and
// rejoined each other every 1-3 s, interrupting each other's jobs. Now the second is
// refused at start, before it touches any job of that name, and the live host's capture
// runs on; a kill -9 and restart of the same host (same data folder, same boot) takes its
// name back at once and interrupts only its own jobs.
// A restarting host first holds its name (state live, no URL) and joins with its URL once
// it serves. In between, a request for its job's frames through another host got a 307
// to a relative location nobody could follow (CI saw it after a restart); now the fleet
// lists the host as starting and the request is refused as not served yet.
TEST_F(ServiceFleet, AHostHoldingItsNameBeforeItServesIsStartingNotARedirect) {
  for (const char* name : {"host-0", "host-1"})
    ASSERT_NE(fleet_->start_host(name, 3000), nullptr) << name;
  ASSERT_TRUE(fleet_->wait_live(*fleet_->host("host-0"), 2).is_object()) << fleet_->logs();
  Daemon& host1 = *fleet_->host("host-1");
  auto capture = host1.post("/v1/cameras/" + url_segment(host1.camera_id()) + "/captures",
                            {{"kind", "single"}});
  ASSERT_EQ(capture.status, 202) << capture.body;
  const int64_t id = capture.json()["id"];
  ASSERT_EQ(host1.wait_job(id, finished, std::chrono::seconds(60))["state"], "succeeded");

  // host-1 stops, and its row is what a new host-1 writes while it starts (take_name with
  // no URL yet; a lease long enough that nobody expires it meanwhile).
  EXPECT_EQ(host1.stop(SIGKILL), 128 + SIGKILL);
  bool ok = false;
  fleet_->cluster().sql("camlab",
                        "UPDATE hosts SET url = '', state = 'live', lease_until = "
                        "clock_timestamp() + interval '60 seconds' WHERE name = 'host-1'",
                        &ok);
  ASSERT_TRUE(ok);
  const Daemon& host0 = *fleet_->host("host-0");
  std::string state;
  for (int i = 0; i < 100 && state != "starting"; ++i) {  // host-0 rereads at each renewal
    const json fleet = host0.get("/v1/fleet").json();
    for (const json& h : fleet["hosts"])
      if (h["name"] == "host-1") state = h["state"].get<std::string>();
    if (state != "starting") std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(state, "starting");
  auto frames = host0.get("/v1/jobs/" + std::to_string(id) + "/frames");
  EXPECT_EQ(frames.status, 503) << frames.body;
  EXPECT_EQ(frames.json()["error"]["code"], "host_unavailable") << frames.body;
  EXPECT_NE(frames.body.find("starting"), std::string::npos) << frames.body;
}

TEST_F(ServiceFleet, ASecondHostWithALiveHostsNameIsRefusedAndARestartRejoins) {
  Daemon* lab = fleet_->start_host("lab", 3000);
  ASSERT_NE(lab, nullptr);
  Daemon* other = fleet_->start_host("other", 3000);
  ASSERT_NE(other, nullptr);
  ASSERT_FALSE(fleet_->wait_live(*lab, 2).is_null()) << fleet_->logs();
  const std::string camera = "/v1/cameras/" + url_segment(lab->camera_id());
  auto capture = lab->post(camera + "/captures", {{"kind", "single"}, {"repeats", 5000}});
  ASSERT_EQ(capture.status, 202) << capture.body;
  const int64_t id = capture.json()["id"];
  auto running = lab->wait_job(id, [](const json& j) { return j["state"] != "queued"; });
  ASSERT_EQ(running["state"], "running") << running.dump();
  auto other_capture = other->post("/v1/cameras/" + url_segment(other->camera_id()) + "/captures",
                                   {{"kind", "single"}, {"repeats", 5000}});
  ASSERT_EQ(other_capture.status, 202) << other_capture.body;
  const int64_t other_id = other_capture.json()["id"];

  // At defaults a fleet host advertises its loopback listen address: said at start.
  EXPECT_NE(lab->log().find("a loopback address"), std::string::npos) << lab->log();
  // The clone: its own folder (another identity), the live host's name.
  EXPECT_EQ(fleet_->start_host("clone", 3000, "", {}, "lab"), nullptr);
  const std::string clone_log = read_file(dir_ / "clone" / "camlabd.1.log");
  EXPECT_NE(clone_log.find("held by another live camlabd"), std::string::npos) << clone_log;
  // Through two of the live host's lease periods, its capture keeps running.
  std::this_thread::sleep_for(std::chrono::milliseconds(6500));
  auto still = lab->get("/v1/jobs/" + std::to_string(id));
  EXPECT_EQ(still.json()["state"], "running") << still.body;

  // kill -9 and restart the real host: it takes its name back without waiting out its
  // lease; its own capture ends interrupted, the other host's runs on.
  EXPECT_EQ(lab->stop(SIGKILL), 128 + SIGKILL);
  const auto restarted_at = std::chrono::steady_clock::now();
  lab = fleet_->start_host("lab", 3000);
  ASSERT_NE(lab, nullptr) << fleet_->logs();
  std::printf(
      "restarted host serving %.2f s after its start (lease 3 s)\n",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - restarted_at).count());
  auto after = lab->get("/v1/jobs/" + std::to_string(id));
  EXPECT_EQ(after.json()["state"], "interrupted") << after.body;
  auto other_after = other->get("/v1/jobs/" + std::to_string(other_id));
  EXPECT_EQ(other_after.json()["state"], "running") << other_after.body;
  for (const auto& [job, states] : history())
    EXPECT_LE(std::count(states.begin(), states.end(), "interrupted"), 1) << "job " << job;
  EXPECT_EQ(other->del("/v1/jobs/" + std::to_string(other_id)).status, 202);
}

TEST_F(ServiceFleet, AHostCutOffFromTheDatabaseEndsItsJobOnceAndRejoins) {
  TcpProxy link(fleet_->cluster().port());
  const std::string via_link =
      "postgresql://postgres@127.0.0.1:" + std::to_string(link.port()) + "/camlab";
  ASSERT_NE(fleet_->start_host("steady", 2000), nullptr);
  Daemon* cut = fleet_->start_host("cut", 2000, via_link);
  ASSERT_NE(cut, nullptr);
  ASSERT_TRUE(fleet_->wait_live(*fleet_->host("steady"), 2).is_object()) << cut->log();
  const std::string camera = "/v1/cameras/" + url_segment(cut->camera_id() + "@cut");
  // A long capture on the host about to be cut off (20 s of frames).
  auto posted =
      fleet_->host("steady")->post(camera + "/captures", {{"kind", "single"}, {"repeats", 2000}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  const int64_t id = posted.json()["id"];
  ASSERT_GT(cut->wait_job(id,
                          [](const json& j) {
                            return j["progress"]["frames_done"].get<int>() >= 20 || finished(j);
                          })["progress"]["frames_done"],
            0);
  link.cut();
  // The steady host expires the silent one's lease and interrupts its job; the cut-off host
  // fenced itself first and stopped capturing.
  const json ended = fleet_->host("steady")->wait_job(id, finished, std::chrono::seconds(30));
  EXPECT_EQ(ended["state"], "interrupted") << ended.dump();
  EXPECT_NE(ended["error"]["message"].get<std::string>().find("lease"), std::string::npos);
  link.restore();
  // It joins again and takes work again.
  ASSERT_TRUE(fleet_->wait_live(*fleet_->host("steady"), 2).is_object()) << cut->log();
  auto again = fleet_->host("steady")->post(camera + "/captures", {{"kind", "single"}});
  ASSERT_EQ(again.status, 202) << again.body;
  const json second = cut->wait_job(again.json()["id"], finished, std::chrono::seconds(30));
  EXPECT_EQ(second["state"], "succeeded") << second.dump();
  const auto h = history().at(id);
  EXPECT_EQ(h, (std::vector<std::string>{"queued", "running", "interrupted"}));
  // The frames written before the cut are whole, the log says why it stopped, and the
  // frames the host wrote after the fleet ended the job, until it fenced itself, are
  // counted once it is back (the review: the database said 31 where the folder held 40;
  // every host, the steady one's cache too, reads the same).
  json job = cut->get("/v1/jobs/" + std::to_string(id)).json();
  const int listed = check_frames(*fleet_->host("steady"), job);
  for (int i = 0; i < 100; ++i) {
    job = fleet_->host("steady")->get("/v1/jobs/" + std::to_string(id)).json();
    if (job["progress"]["frames_done"].get<int>() == listed) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(job["progress"]["frames_done"].get<int>(), listed) << job.dump();
  EXPECT_EQ(cut->get("/v1/jobs/" + std::to_string(id)).json()["progress"]["frames_done"], listed);
  EXPECT_NE(cut->log().find("fenced itself"), std::string::npos);
}

}  // namespace
