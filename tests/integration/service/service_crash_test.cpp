// camlabd killed with SIGKILL at random instants during 20 captures, restarted after each:
// every capture folder reads back consistent through the API (each frame listed downloads
// whole and says its index), the database counts exactly the frames the folder lists, and
// no temporary or unlisted frame file is left once camlabd has started again.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>

#include "daemon_harness.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

// The test camera with noise on, at 10 ms frames: frames that do not compress to nothing,
// written fast.
std::string noisy_camera_spec() {
  json camera = json::parse(kTestCameraSpec);
  camera["name"] = "camlabd crash test camera 160x120";
  camera["sensor"]["read_noise_e"] = 2.0;
  camera["sensor"]["shot_noise"] = true;
  camera["timing"]["frame_interval_us"] = 10000;
  camera["controls"]["exposure_time_absolute"]["max"] = 100;  // within the 10 ms frame
  return camera.dump();
}

class ServiceCrash : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fresh_test_dir("crash");
    write_test_specs(dir);
    std::ofstream(dir / "camera.json") << noisy_camera_spec();
    args = {"--no-scan", "--camera-spec", (dir / "camera.json").string(), "--scene",
            (dir / "scene.json").string()};
  }
  void TearDown() override { fs::remove_all(dir); }

  // What a restarted camlabd shows of job `id`, checked against its folder on disk.
  void check_job_after_restart(const Daemon& daemon, int64_t id, int run) {
    SCOPED_TRACE("run " + std::to_string(run) + ", job " + std::to_string(id));
    const std::string base = "/v1/jobs/" + std::to_string(id);
    const json job = daemon.get(base).json();
    ASSERT_TRUE(job.is_object());
    const std::string state = job.value("state", "");
    EXPECT_TRUE(state == "interrupted" || state == "succeeded") << job.dump();
    const int counted = job["progress"]["frames_done"].get<int>();

    auto listing = daemon.get(base + "/frames");
    const fs::path folder = dir / "data" / job.value("folder", "");
    if (listing.status == 404) {  // killed before the capture made its folder
      EXPECT_EQ(counted, 0);
      return;
    }
    ASSERT_EQ(listing.status, 200) << listing.body;
    const json frames = listing.json()["frames"];
    EXPECT_EQ(counted, static_cast<int>(frames.size()))
        << "the database counts what the folder lists";
    uint64_t previous_sequence = 0;
    for (size_t i = 0; i < frames.size(); ++i) {
      auto png = daemon.get(base + "/frames/" + std::to_string(i));
      ASSERT_EQ(png.status, 200) << "frame " << i;
      const cv::Mat image =
          cv::imdecode(std::vector<uchar>(png.body.begin(), png.body.end()), cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << "frame " << i << " is not a whole PNG";
      EXPECT_EQ(image.size(), cv::Size(160, 120)) << "frame " << i;
      const json meta = daemon.get(base + "/frames/" + std::to_string(i) + "/meta").json();
      ASSERT_TRUE(meta.is_object()) << "frame " << i << "'s sidecar is not whole";
      EXPECT_EQ(meta["index"], i);
      const uint64_t sequence = meta["sequence"].get<uint64_t>();
      if (i > 0) {
        EXPECT_GT(sequence, previous_sequence) << "frame " << i;
      }
      previous_sequence = sequence;
    }
    // On disk: the manifest, the journal and the listed frames' files, nothing else.
    size_t frame_files = 0;
    for (const auto& entry : fs::directory_iterator(folder)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("frame_", 0) == 0) {
        ++frame_files;
      } else {
        EXPECT_TRUE(name == "manifest.json" || name == "frames.jsonl") << name << " left behind";
      }
    }
    EXPECT_EQ(frame_files, 2 * frames.size()) << "unlisted frame files left behind";
  }

  fs::path dir;
  std::vector<std::string> args;
};

TEST_F(ServiceCrash, KillNineAtRandomInstantsDuringTwentyCapturesLeavesEveryFolderConsistent) {
  std::mt19937 rng(1125);
  // Each kill comes once the job has listed a random number of frames (0: as soon as it
  // is accepted, possibly before it starts), then a random 0-40 ms later: mid-frame,
  // mid-commit, mid-count.
  std::uniform_int_distribution<int> frames_before_kill(0, 48), delay_ms(0, 40);
  std::vector<int64_t> jobs;
  int killed_mid_capture = 0;
  for (int run = 0; run < 20; ++run) {
    Daemon daemon;
    ASSERT_TRUE(daemon.start(dir, args)) << daemon.log();
    if (!jobs.empty()) check_job_after_restart(daemon, jobs.back(), run - 1);
    const std::string camera = "/v1/cameras/" + url_segment(daemon.camera_id());
    const json request = run % 2 ? json{{"kind", "single"}, {"repeats", 100}}
                                 : json{{"kind", "bracket"},
                                        {"exposures_us", {1000, 2000, 3000, 4000}},
                                        {"repeats", 25}};
    auto posted = daemon.post(camera + "/captures", request);
    ASSERT_EQ(posted.status, 202) << posted.body;
    const int64_t id = posted.json()["id"];
    jobs.push_back(id);
    const int target = frames_before_kill(rng);
    const json job = daemon.wait_job(
        id,
        [&](const json& j) {
          return j["progress"]["frames_done"].get<int>() >= target ||
                 (j.value("state", "") != "queued" && j.value("state", "") != "running");
        },
        30s);
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    EXPECT_EQ(daemon.stop(SIGKILL), 128 + SIGKILL);
    killed_mid_capture += job.value("state", "") == "running" && target > 0;
  }
  Daemon last;
  ASSERT_TRUE(last.start(dir, args)) << last.log();
  check_job_after_restart(last, jobs.back(), 19);
  // Every job once more, now that all were recovered: nothing changed since.
  for (size_t k = 0; k < jobs.size(); ++k)
    check_job_after_restart(last, jobs[k], static_cast<int>(k));
  EXPECT_EQ(last.get("/v1/jobs?state=running").json()["jobs"].size(), 0u);
  // No temporaries anywhere under the captures.
  for (const auto& entry : fs::recursive_directory_iterator(dir / "data" / "captures"))
    EXPECT_NE(entry.path().filename().string()[0], '.') << entry.path();
  EXPECT_GE(killed_mid_capture, 10) << "most kills must land mid-capture";
  EXPECT_EQ(last.stop(SIGTERM), 0) << last.log();
}

}  // namespace
