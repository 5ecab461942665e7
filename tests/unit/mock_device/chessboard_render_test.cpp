// Geometry of the renderer against its truth: OpenCV finds the chessboard corners where
// the truth's exact mrcal projection says they are, and the truth's .cameramodel is one
// that mrcal itself (C API and Python tools) loads and projects identically.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "calib/corners/chessboard_corners.h"
#include "mock_device/spec/mrcal_api.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

const std::filesystem::path kExamples =
    std::filesystem::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";

class ChessboardRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto camera = load_camera_spec(kExamples / "camera_wide_1280x800.json");
    auto scene = load_scene_spec(kExamples / "scene_chessboard_calibration.json");
    ASSERT_TRUE(camera.ok() && scene.ok());
    auto r = Renderer::create(std::move(*camera), std::move(*scene));
    ASSERT_TRUE(r.ok()) << r.error().message;
    renderer_ = new Renderer(std::move(*r));
  }
  static void TearDownTestSuite() { delete renderer_; }
  static Renderer* renderer_;
};
Renderer* ChessboardRender::renderer_ = nullptr;

TEST_F(ChessboardRender, OpenCvCornersMatchTheTruthWithinATenthOfAPixel) {
  double sum_sq = 0;
  int corners = 0, views_found = 0;
  const int views = 6;
  for (int view = 0; view < views; ++view) {
    RenderOptions options;
    options.frame_number = view;
    auto frame = renderer_->render(renderer_->default_settings(), view, options);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    const auto& truth = frame->truth["targets"][0]["corners_px"];
    auto found = calib::find_chessboard_corners(frame->image, 14, 10);
    if (!found.ok()) continue;
    ++views_found;
    // A chessboard is symmetric under a half turn: match the detection's orientation to
    // the truth by its first corner.
    auto& detected = found->corners_px;
    ASSERT_EQ(detected.size(), truth.size());
    auto dist = [&](size_t i, size_t j) {
      return std::hypot(detected[i].x - truth[j][0].get<double>(),
                        detected[i].y - truth[j][1].get<double>());
    };
    if (dist(0, truth.size() - 1) < dist(0, 0)) std::reverse(detected.begin(), detected.end());
    for (size_t i = 0; i < detected.size(); ++i) {
      ASSERT_FALSE(truth[i].is_null()) << "truth marks a detected corner as off the imager";
      const double d = dist(i, i);
      ASSERT_LT(d, 1.0) << "view " << view << " corner " << i << " is a mismatch";
      sum_sq += d * d;
      ++corners;
    }
  }
  ASSERT_GE(views_found, 4) << "the detector should find most boards of the example set";
  const double rms_px = std::sqrt(sum_sq / corners);
  RecordProperty("corner_rms_px", std::to_string(rms_px));
  std::printf("corner RMS against truth: %.4f px over %d corners in %d views\n", rms_px, corners,
              views_found);
  EXPECT_LT(rms_px, 0.1) << corners << " corners in " << views_found << " views";
}

TEST_F(ChessboardRender, TruthCameraModelLoadsInMrcalAtFullPrecision) {
  auto frame = renderer_->render(renderer_->default_settings(), 0, RenderOptions{.noise = false});
  ASSERT_TRUE(frame.ok());
  const std::string text = frame->truth["cameramodel"].get<std::string>();
  mrcal_cameramodel_t* model =
      mrcal_read_cameramodel_string(text.c_str(), static_cast<int>(text.size()));
  ASSERT_NE(model, nullptr) << text;
  const auto& intrinsics = frame->truth["intrinsics"];
  ASSERT_EQ(mrcal_lensmodel_num_params(&model->lensmodel), static_cast<int>(intrinsics.size()));
  for (size_t i = 0; i < intrinsics.size(); ++i)
    EXPECT_EQ(model->intrinsics[i], intrinsics[i].get<double>())
        << "intrinsic " << i << " lost precision";
  EXPECT_EQ(model->imagersize[0], 1280u);
  mrcal_free_cameramodel(&model);
}

TEST_F(ChessboardRender, MrcalPythonToolsProjectTheTruthCornersIdentically) {
  if (!std::filesystem::exists("/usr/bin/python3")) GTEST_SKIP() << "Debian's python3 is absent";
  auto frame = renderer_->render(renderer_->default_settings(), 1, RenderOptions{.noise = false});
  ASSERT_TRUE(frame.ok());
  const auto dir =
      std::filesystem::temp_directory_path() / ("camlab_mrcal_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "truth.cameramodel") << frame->truth["cameramodel"].get<std::string>();
  const auto& board = frame->truth["targets"][0];
  // mrcal.ref_calibration_object gives mrcal's own board geometry; projecting it through
  // the loaded model must give the truth's corners.
  std::ofstream(dir / "check.py")
      << "import sys, json, numpy as np, mrcal\n"
      << "m = mrcal.cameramodel(sys.argv[1])\n"
      << "rt = np.array(json.loads(sys.argv[2]))\n"
      << "obj = mrcal.ref_calibration_object(14, 10, " << board["square_m"].get<double>() << ")\n"
      << "q = mrcal.project(mrcal.transform_point_rt(rt, obj), *m.intrinsics())\n"
      << "print(json.dumps(q.reshape(-1, 2).tolist()))\n";
  const std::string command = "/usr/bin/python3 " + (dir / "check.py").string() + " " +
                              (dir / "truth.cameramodel").string() + " '" +
                              board["rt_cam_target"].dump() + "'";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  ASSERT_EQ(pclose(pipe), 0) << "mrcal could not load the truth model: " << output;
  std::filesystem::remove_all(dir);
  const auto projected = nlohmann::json::parse(output);
  const auto& truth = board["corners_px"];
  ASSERT_EQ(projected.size(), truth.size());
  for (size_t i = 0; i < truth.size(); ++i) {
    if (truth[i].is_null()) continue;
    EXPECT_NEAR(projected[i][0].get<double>(), truth[i][0].get<double>(), 1e-6);
    EXPECT_NEAR(projected[i][1].get<double>(), truth[i][1].get<double>(), 1e-6);
  }
}

// Moving the board (set_target_pose) renders exactly what a scene spec with that pose
// renders: the same image bits and the same corner truth. The spec path is the
// independent one: it parses the pose and builds a new renderer.
TEST(TargetMove, RendersWhatASpecWithThatPoseRenders) {
  auto camera = load_camera_spec(kExamples / "camera_wide_1280x800.json");
  auto scene = load_scene_spec(kExamples / "scene_chessboard_calibration.json");
  ASSERT_TRUE(camera.ok() && scene.ok());
  auto moved = Renderer::create(*camera, *scene);
  ASSERT_TRUE(moved.ok());
  const RtCamTarget pose = {0.2, -0.3, 0.05, -0.25, -0.12, 0.7};
  RenderOptions options;
  options.frame_number = 3;
  // Render once before the move, so a stale cached integral would show.
  ASSERT_TRUE(moved->render(moved->default_settings(), 5, options).ok());
  ASSERT_TRUE(moved->set_target_pose("board", 5, pose).ok());
  auto after = moved->render(moved->default_settings(), 5, options);
  ASSERT_TRUE(after.ok());

  scene->targets[0].poses[5] = pose;
  auto fresh = Renderer::create(*camera, *scene);
  ASSERT_TRUE(fresh.ok());
  auto expected = fresh->render(fresh->default_settings(), 5, options);
  ASSERT_TRUE(expected.ok());
  EXPECT_EQ(cv::norm(after->image, expected->image, cv::NORM_INF), 0.0);
  EXPECT_EQ(after->truth["targets"][0]["corners_px"], expected->truth["targets"][0]["corners_px"]);
  // The other views keep their poses.
  EXPECT_EQ(moved->scene().targets[0].poses[4], fresh->scene().targets[0].poses[4]);

  EXPECT_EQ(moved->set_target_pose("no such board", 5, pose).error().code, "not_found");
  EXPECT_EQ(moved->set_target_pose("board", 40, pose).error().code, "out_of_range");
  RtCamTarget behind = pose;
  behind[5] = -0.5;
  EXPECT_EQ(moved->set_target_pose("board", 5, behind).error().code, "out_of_range");
  behind[5] = std::nan("");
  EXPECT_EQ(moved->set_target_pose("board", 5, behind).error().code, "out_of_range");
}

}  // namespace
}  // namespace camlab::mock
