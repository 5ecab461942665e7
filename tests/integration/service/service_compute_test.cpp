// POST /v1/analyses and POST /v1/calibrations: jobs running the analysis and calibration
// libraries on capture folders (a daemon capture, and a rendered calibration set placed
// under the data folder), with their sources validated.
#include <gtest/gtest.h>

#include <fstream>
#include <set>

#include "daemon_harness.h"
#include "tests/integration/cli_runner.h"

namespace {

using namespace camlab::testing;
using nlohmann::json;

// The first value stored under `key` anywhere in `j`, or null.
json find_key(const json& j, const std::string& key) {
  if (j.is_object()) {
    if (j.contains(key)) return j[key];
    for (const auto& [k, v] : j.items())
      if (auto found = find_key(v, key); !found.is_null()) return found;
  } else if (j.is_array()) {
    for (const auto& v : j)
      if (auto found = find_key(v, key); !found.is_null()) return found;
  }
  return nullptr;
}

class ServiceCompute : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fresh_test_dir(std::string("compute_") +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    write_test_specs(dir);
    ASSERT_TRUE(daemon.start(dir, {"--no-scan", "--camera-spec", (dir / "camera.json").string(),
                                   "--scene", (dir / "scene.json").string()}))
        << daemon.log();
    camera = "/v1/cameras/" + url_segment(daemon.camera_id());
  }
  void TearDown() override {
    daemon.stop(SIGTERM);
    fs::remove_all(dir);
  }
  fs::path dir;
  Daemon daemon;
  std::string camera;
};

TEST_F(ServiceCompute, ExposureAnalysisOfABracketReportsLinearity) {
  auto capture = daemon.post(camera + "/captures", {{"kind", "bracket"},
                                                    {"exposures_us", {2000, 4000, 8000}},
                                                    {"repeats", 2},
                                                    {"controls", {{"iris_absolute", 5}}}});
  ASSERT_EQ(capture.status, 202) << capture.body;
  const int64_t capture_id = capture.json()["id"];
  // A source that is still running is refused.
  auto early = daemon.post("/v1/analyses", {{"kind", "exposure"}, {"job", capture_id}});
  if (early.status != 202) {
    EXPECT_EQ(early.status, 409) << early.body;
  }
  ASSERT_EQ(daemon.wait_finished(capture_id)["state"], "succeeded");
  auto r = daemon.post("/v1/analyses", {{"kind", "exposure"}, {"job", capture_id}});
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"]);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const json linearity_error = find_key(job["result"]["report"], "max_abs_error_pct");
  ASSERT_TRUE(linearity_error.is_number()) << job["result"].dump();
  EXPECT_LT(linearity_error.get<double>(), 2.0) << job["result"]["report"]["linearity"].dump();
}

TEST_F(ServiceCompute, SourcesAreValidated) {
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "exposure"}, {"job", 4242}}).status, 404);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "colour"}, {"job", 1}}).status, 400);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "../../etc"}}).status, 400);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "/etc"}}).status, 400);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "captures/none"}}).status,
            404);
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}}).status, 400);
  fs::create_symlink("/etc", dir / "data" / "escape");
  EXPECT_EQ(daemon.post("/v1/analyses", {{"kind", "focus"}, {"folder", "escape"}}).status, 400);
  EXPECT_EQ(daemon
                .post("/v1/calibrations",
                      {{"folder", "captures"}, {"inner_corners", {14}}, {"spacing_m", 0.04}})
                .status,
            400);
}

TEST_F(ServiceCompute, CalibrationOfARenderedChessboardSetRecoversTheFocalLength) {
  const fs::path set = dir / "data" / "imports" / "calibration-set";
  auto render =
      run_cli("render --camera " CAMLAB_SOURCE_DIR
              "/mock_device/examples/camera_wide_1280x800.json --scene " CAMLAB_SOURCE_DIR
              "/mock_device/examples/scene_chessboard_calibration.json --quiet"
              " --view 0 --view 5 --view 10 --view 15 --view 20 --view 25 --view 30 --out " +
              set.string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  auto bad = daemon.post(
      "/v1/calibrations",
      {{"folder", "imports/calibration-set"}, {"inner_corners", {14, 10}}, {"spacing_m", -1}});
  EXPECT_EQ(bad.status, 422);
  // mrgingham finds square boards only: refused before any work, with the reason.
  auto not_square = daemon.post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                                     {"inner_corners", {14, 10}},
                                                     {"spacing_m", 0.04},
                                                     {"detector", "mrgingham"}});
  EXPECT_EQ(not_square.status, 422) << not_square.body;
  EXPECT_NE(not_square.body.find("square"), std::string::npos) << not_square.body;
  EXPECT_EQ(daemon
                .post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                           {"inner_corners", {14, 10}},
                                           {"spacing_m", 0.04},
                                           {"detector", "harris"}})
                .status,
            400);
  // A board larger than the one in the frames is found in none: a failed job that says
  // so, not an empty model. (A smaller one can be found inside the real board.)
  auto wrong_board = daemon.post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                                      {"inner_corners", {15, 11}},
                                                      {"spacing_m", 0.04},
                                                      {"model", "LENSMODEL_OPENCV4"}});
  ASSERT_EQ(wrong_board.status, 202) << wrong_board.body;
  const json failed = daemon.wait_finished(wrong_board.json()["id"], std::chrono::seconds(300));
  EXPECT_EQ(failed["state"], "failed") << failed.dump();
  EXPECT_NE(failed.dump().find("no_board"), std::string::npos) << failed.dump();
  auto r = daemon.post("/v1/calibrations", {{"folder", "imports/calibration-set"},
                                            {"inner_corners", {14, 10}},
                                            {"spacing_m", 0.04},
                                            {"model", "LENSMODEL_OPENCV8"}});
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"], std::chrono::seconds(300));
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  EXPECT_NE(job["result"]["cameramodel"].get<std::string>().find("LENSMODEL_OPENCV8"),
            std::string::npos);
  const json fx = find_key(job["result"]["report"], "fx_px");
  ASSERT_TRUE(fx.is_number()) << job["result"]["report"].dump();
  EXPECT_NEAR(fx.get<double>(), 2.2 / 0.003, 0.02 * 2.2 / 0.003)
      << "fx against the spec's f / pitch";
  // The model file is the CLI's: it carries mrcal's optimization inputs.
  std::ifstream model_file(dir / "data" / job["folder"].get<std::string>() / "camera.cameramodel");
  ASSERT_TRUE(model_file) << "no camera.cameramodel in the job's folder";
  const std::string model_text((std::istreambuf_iterator<char>(model_file)),
                               std::istreambuf_iterator<char>());
  EXPECT_NE(model_text.find("'optimization_inputs'"), std::string::npos);
  EXPECT_EQ(job["result"]["report"]["detector"]["requested"], "auto");
  // The plots the dashboard shows: residuals and the projection uncertainty, as PNG.
  std::set<std::string> plots;
  const std::string plots_path = "/v1/jobs/" + std::to_string(job["id"].get<int64_t>()) + "/plots";
  const json listed = daemon.get(plots_path).json();
  for (const auto& p : listed["plots"]) plots.insert(p["name"].get<std::string>());
  EXPECT_TRUE(plots.count("residuals.png")) << daemon.get(plots_path).body;
  EXPECT_TRUE(plots.count("uncertainty.png")) << daemon.get(plots_path).body;
  auto png = daemon.get(plots_path + "/residuals.png");
  EXPECT_EQ(png.status, 200);
  EXPECT_EQ(png.body.substr(1, 3), "PNG");
}

// A ChArUco board through POST /v1/calibrations: views cut by the frame's edge kept
// (views 26-39 of the example set are cut), focal length against the spec's f / pitch.
TEST_F(ServiceCompute, CalibrationOfARenderedCharucoSetKeepsCutViews) {
  const fs::path set = dir / "data" / "imports" / "charuco-set";
  auto render =
      run_cli("render --camera " CAMLAB_SOURCE_DIR
              "/mock_device/examples/camera_wide_1280x800.json --scene " CAMLAB_SOURCE_DIR
              "/mock_device/examples/scene_charuco_calibration.json --quiet"
              " --view 0 --view 4 --view 8 --view 12 --view 16 --view 26 --view 30 --view 34"
              " --view 38 --out " +
              set.string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const json board = {
      {"folder", "imports/charuco-set"}, {"inner_corners", {10, 7}}, {"spacing_m", 0.06},
      {"detector", "charuco"},           {"marker_m", 0.045},        {"dictionary", "DICT_4X4_50"},
      {"model", "LENSMODEL_OPENCV8"}};
  json too_big_marker = board;
  too_big_marker["marker_m"] = 0.07;
  EXPECT_EQ(daemon.post("/v1/calibrations", too_big_marker).status, 422);
  json unknown_dictionary = board;
  unknown_dictionary["dictionary"] = "DICT_9X9_1";
  EXPECT_GE(daemon.post("/v1/calibrations", unknown_dictionary).status, 400);
  json markers_without_charuco = board;
  markers_without_charuco["detector"] = "auto";
  EXPECT_EQ(daemon.post("/v1/calibrations", markers_without_charuco).status, 400);
  auto r = daemon.post("/v1/calibrations", board);
  ASSERT_EQ(r.status, 202) << r.body;
  const json job = daemon.wait_finished(r.json()["id"], std::chrono::seconds(300));
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const json fx = find_key(job["result"]["report"], "fx_px");
  ASSERT_TRUE(fx.is_number()) << job["result"]["report"].dump();
  EXPECT_NEAR(fx.get<double>(), 2.2 / 0.003, 0.02 * 2.2 / 0.003);
  EXPECT_EQ(job["result"]["report"]["detector"]["requested"], "charuco");
}

}  // namespace
