// `camlab calibrate --suggest` and `--watch` end to end on frames the virtual camera
// renders (`camlab render`, the example chessboard scene through the wide 1280x800 lens):
// the suggestion's fields in the JSON report, and a watched folder that grows by copied
// images (each detected once, a suggestion after each, the outputs written at the end).
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "calib/mrcal_api.h"
#include "tests/integration/cli_runner.h"

namespace camlab::calib {
namespace {

namespace fs = std::filesystem;

constexpr int kFrames = 6;

// Renders views 0..kFrames-1 of the example chessboard scene once per test program; the
// folder goes when the program ends.
struct RenderedFrames {
  fs::path dir;
  ~RenderedFrames() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

const fs::path& rendered() {
  static const RenderedFrames frames = [] {
    RenderedFrames r;
    r.dir = fs::temp_directory_path() / ("camlab_watch_render_" + std::to_string(getpid()));
    fs::remove_all(r.dir);
    std::string views;
    for (int i = 0; i < kFrames; ++i) views += " " + std::to_string(i);
    const auto run = camlab::testing::run_cli(
        std::string("render --camera ") + CAMLAB_SOURCE_DIR +
        "/mock_device/examples/camera_wide_1280x800.json --scene " + CAMLAB_SOURCE_DIR +
        "/mock_device/examples/scene_chessboard_calibration.json --quiet --out " + r.dir.string() +
        " --view" + views);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return r;
  }();
  return frames.dir;
}

fs::path frame(int i) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%06d.png", i);
  return rendered() / name;
}

class CalibrateWatch : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("camlab_watch_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "watched");
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

std::vector<nlohmann::json> json_lines(const std::string& out) {
  std::vector<nlohmann::json> lines;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

TEST_F(CalibrateWatch, SuggestPrintsEveryFieldOfTheNextView) {
  for (int i = 0; i < kFrames; ++i) fs::copy_file(frame(i), dir_ / "watched" / frame(i).filename());
  const std::string common = "calibrate --images " + (dir_ / "watched").string() +
                             " --board 14x10 --spacing-m 0.04 --model LENSMODEL_OPENCV8 --quiet"
                             " --suggest --out " +
                             (dir_ / "cam.cameramodel").string();
  const auto run = camlab::testing::run_cli(common + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  ASSERT_TRUE(report.contains("suggestion")) << run.out;
  const auto& s = report["suggestion"];
  for (const char* key : {"rt_cam_board", "centre_x_px", "centre_y_px", "bounds_px", "distance_m",
                          "tilt_about_x_deg", "tilt_about_y_deg", "region", "description",
                          "worst_now_px", "predicted_worst_px", "opening"})
    EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_EQ(s["rt_cam_board"].size(), 6u);
  EXPECT_FALSE(s["opening"].get<bool>());
  EXPECT_LT(s["predicted_worst_px"].get<double>(), s["worst_now_px"].get<double>());
  // The suggestion's "now" is the coverage's worst, over the same grid and distance.
  ASSERT_TRUE(report.contains("coverage"));
  EXPECT_DOUBLE_EQ(report["coverage"]["worst_of_grid_px"].get<double>(),
                   s["worst_now_px"].get<double>());
  EXPECT_EQ(report["coverage"]["worst_px"].size(), 160u);

  const auto text = camlab::testing::run_cli(common);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("Guided calibration: worst projection uncertainty"), std::string::npos)
      << text.out;
  EXPECT_NE(text.out.find(s["description"].get<std::string>()), std::string::npos) << text.out;
}

// Images copied into the folder one by one (written under another name, then renamed, as
// a capture program should; a copy in progress would also wait for its size to settle).
TEST_F(CalibrateWatch, WatchDetectsEachNewImageOnceAndSuggestsAfterEach) {
  const fs::path watched = dir_ / "watched";
  ASSERT_TRUE(fs::exists(frame(kFrames - 1)));  // rendered before the watch's clock starts
  camlab::testing::CliRun run;
  std::thread cli([&] {
    run = camlab::testing::run_cli("calibrate --images " + watched.string() +
                                   " --board 14x10 --spacing-m 0.04 --watch --json --quiet"
                                   " --watch-poll-s 0.1 --watch-timeout-s 3 --out " +
                                   (dir_ / "cam.cameramodel").string() + " --report " +
                                   (dir_ / "report.json").string());
  });
  for (int i = 0; i < kFrames; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    fs::copy_file(frame(i), watched / ".incoming");
    fs::rename(watched / ".incoming", watched / frame(i).filename());
  }
  // The first view again under another name: the board where it was, not taken.
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  fs::copy_file(frame(0), watched / ".incoming");
  fs::rename(watched / ".incoming", watched / "repeat.png");
  cli.join();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto lines = json_lines(run.out);
  ASSERT_GE(lines.size(), 2u) << run.out;
  int detected = 0, rounds_with_suggestion = 0;
  size_t last_views = 0;
  std::string skipped;
  for (size_t i = 0; i + 1 < lines.size(); ++i) {
    const auto& l = lines[i];
    ASSERT_EQ(l["event"], "round") << l.dump();
    detected += l["new_images"].get<int>();
    EXPECT_GE(l["views"].get<size_t>(), last_views);
    last_views = l["views"].get<size_t>();
    if (l.contains("suggestion")) ++rounds_with_suggestion;
    if (l.contains("skipped")) skipped += l["skipped"].dump();
    // From the second view on the data are solved and the suggestion predicts a gain.
    if (l["views"].get<int>() >= 2 && l.contains("coverage")) {
      EXPECT_FALSE(l["suggestion"]["opening"].get<bool>()) << l.dump();
      EXPECT_LT(l["suggestion"]["predicted_worst_px"].get<double>(),
                l["coverage"]["worst_of_grid_px"].get<double>());
    }
  }
  EXPECT_EQ(detected, kFrames + 1);  // each image detected once, never again
  EXPECT_EQ(last_views, static_cast<size_t>(kFrames));
  EXPECT_NE(skipped.find("repeat.png: the board sits where it sat in view 0"), std::string::npos)
      << skipped;
  EXPECT_EQ(rounds_with_suggestion, static_cast<int>(lines.size()) - 1);
  const auto& done = lines.back();
  EXPECT_EQ(done["event"], "done");
  EXPECT_EQ(done["reason"], "timeout");
  EXPECT_EQ(done["report"]["images"].get<int>(), kFrames + 1);  // the repeat read, not taken
  // `--model auto`: the loop solved LENSMODEL_OPENCV8; the end is the full calibration, as
  // camlabd's sessions finish: model selection over the candidates, on every view.
  EXPECT_GE(done["report"]["model_selection"].size(), 2u) << done["report"].dump();
  // The model written at the end is the wide lens: f 2.2 mm on 3 um pixels = 733.3 px.
  mrcal_cameramodel_t* model = mrcal_read_cameramodel_file((dir_ / "cam.cameramodel").c_str());
  ASSERT_NE(model, nullptr);
  EXPECT_NEAR(model->intrinsics[0], 733.33, 0.01 * 733.33);
  mrcal_free_cameramodel(&model);
  EXPECT_TRUE(fs::exists(dir_ / "report.json"));
}

TEST_F(CalibrateWatch, WatchEndsAtTheTarget) {
  const fs::path watched = dir_ / "watched";
  for (int i = 0; i < 3; ++i) fs::copy_file(frame(i), watched / frame(i).filename());
  // Three views leave the imager's corners uncertain by far more than 0.01 px but less
  // than 1e4 px: the first target ends the watch at the first solve, the second never.
  const std::string common = "calibrate --images " + watched.string() +
                             " --board 14x10 --spacing-m 0.04 --watch --json --quiet"
                             " --watch-poll-s 0.1 --watch-timeout-s 1 --out " +
                             (dir_ / "cam.cameramodel").string();
  const auto reached = camlab::testing::run_cli(common + " --target-uncertainty-px 10000");
  ASSERT_EQ(reached.exit_code, 0) << reached.err;
  const auto lines = json_lines(reached.out);
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back()["reason"], "target") << reached.out;
  const auto not_reached = camlab::testing::run_cli(common + " --target-uncertainty-px 0.01");
  ASSERT_EQ(not_reached.exit_code, 0) << not_reached.err;
  EXPECT_EQ(json_lines(not_reached.out).back()["reason"], "timeout") << not_reached.out;
}

// Ctrl-C ends the watch like the timeout: the outputs of the views so far are written.
TEST_F(CalibrateWatch, InterruptEndsTheWatchAndWritesTheOutputs) {
  const fs::path watched = dir_ / "watched";
  for (int i = 0; i < 3; ++i) fs::copy_file(frame(i), watched / frame(i).filename());
  const std::string out_path = (dir_ / "out.jsonl").string();
  const std::string model_path = (dir_ / "cam.cameramodel").string();
  const std::string images = watched.string();
  std::vector<std::string> args = {CAMLAB_CLI_PATH,
                                   "calibrate",
                                   "--images",
                                   images,
                                   "--board",
                                   "14x10",
                                   "--spacing-m",
                                   "0.04",
                                   "--watch",
                                   "--json",
                                   "--quiet",
                                   "--watch-poll-s",
                                   "0.1",
                                   "--watch-timeout-s",
                                   "60",
                                   "--out",
                                   model_path};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, CAMLAB_CLI_PATH, &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  // Wait (at most 30 s) for the round that solved the three views, then interrupt.
  bool solved = false;
  for (int k = 0; k < 300 && !solved; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::ifstream in(out_path);
    std::stringstream text;
    text << in.rdbuf();
    solved = text.str().find("\"views\":3") != std::string::npos;
  }
  EXPECT_TRUE(solved);
  kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  std::ifstream in(out_path);
  std::stringstream text;
  text << in.rdbuf();
  const auto lines = json_lines(text.str());
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back()["reason"], "interrupted") << text.str();
  EXPECT_TRUE(fs::exists(model_path));
}

TEST_F(CalibrateWatch, BadWatchArgumentsAreRefused) {
  const std::string base =
      "calibrate --board 14x10 --spacing-m 0.04 --out " + (dir_ / "cam.cameramodel").string();
  const auto no_images =
      camlab::testing::run_cli(base + " --corners x.vnl --imager 640x480 --watch");
  EXPECT_EQ(no_images.exit_code, 2);
  EXPECT_NE(no_images.err.find("--watch needs --images"), std::string::npos) << no_images.err;
  const auto timeout = camlab::testing::run_cli(base + " --images " + (dir_ / "watched").string() +
                                                " --watch --watch-timeout-s 0");
  EXPECT_EQ(timeout.exit_code, 2);
  EXPECT_NE(timeout.err.find("--watch-timeout-s"), std::string::npos) << timeout.err;
  const auto target = camlab::testing::run_cli(base + " --images " + (dir_ / "watched").string() +
                                               " --watch --target-uncertainty-px -1");
  EXPECT_EQ(target.exit_code, 2);
  EXPECT_NE(target.err.find("--target-uncertainty-px"), std::string::npos) << target.err;
}

}  // namespace
}  // namespace camlab::calib
