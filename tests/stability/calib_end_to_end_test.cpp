// Calibration's acceptance test, end to end on the virtual camera: chessboard views rendered
// through the known OPENCV8 wide lens (mock_device/examples, 1280x800) are calibrated
// from the images by `camlab calibrate --job`; the result must project within 0.2 px RMS
// of the truth over the central 80% of the imager, and its FOV must be within 0.2 deg.
// 10 of the scene's 40 views keep the render near 10 s on 2 cores. The diagonal FOV is
// printed, not checked: the image corners lie beyond the boards of 10 views, so the
// diagonal is extrapolation (the report's border coverage says so).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "calib/lens_model.h"
#include "calib/mrcal_api.h"
#include "tests/integration/cli_runner.h"

namespace camlab::calib {
namespace {

namespace fs = std::filesystem;

LensModel read_model(const mrcal_cameramodel_t* m) {
  char name[256];
  mrcal_lensmodel_name(name, sizeof name, &m->lensmodel);
  const int n = mrcal_lensmodel_num_params(&m->lensmodel);
  return {name, std::vector<double>(m->intrinsics, m->intrinsics + n),
          static_cast<int>(m->imagersize[0]), static_cast<int>(m->imagersize[1])};
}

TEST(CalibEndToEnd, RenderedWideOpencv8ChessboardViews) {
  const fs::path dir = fs::temp_directory_path() / ("camlab_calib_e2e_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string src = CAMLAB_SOURCE_DIR;
  // Views spread over the set (the sector detector finds the board in each of these).
  std::string views;
  for (int v : {1, 4, 7, 10, 13, 16, 21, 26, 31, 36}) views += " --view " + std::to_string(v);
  auto run = camlab::testing::run_cli(
      "render --camera " + src + "/mock_device/examples/camera_wide_1280x800.json --scene " + src +
      "/mock_device/examples/scene_chessboard_calibration.json --quiet --out " +
      (dir / "frames").string() + views);
  ASSERT_EQ(run.exit_code, 0) << run.err;

  run = camlab::testing::run_cli(
      "calibrate --job " + (dir / "frames").string() +
      " --board 14x10 --spacing-m 0.04 --model LENSMODEL_OPENCV8 --pixel-um 3"
      " --quiet --out " +
      (dir / "cam.cameramodel").string() + " --report " + (dir / "report.json").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;

  std::ifstream sidecar(dir / "frames" / "frame_000000.json");
  const auto truth_json = nlohmann::json::parse(sidecar);
  const std::string truth_text = truth_json["truth"]["cameramodel"].get<std::string>();
  mrcal_cameramodel_t* truth_m = mrcal_read_cameramodel_string(truth_text.c_str(), 0);
  mrcal_cameramodel_t* fitted_m = mrcal_read_cameramodel_file((dir / "cam.cameramodel").c_str());
  ASSERT_NE(truth_m, nullptr);
  ASSERT_NE(fitted_m, nullptr);
  const LensModel truth = read_model(truth_m), fitted = read_model(fitted_m);
  mrcal_free_cameramodel(&truth_m);
  mrcal_free_cameramodel(&fitted_m);

  auto diff = projection_difference(truth, fitted, 0.8);
  ASSERT_TRUE(diff.ok()) << diff.error().message;
  auto fov_truth = field_of_view(truth);
  auto fov = field_of_view(fitted);
  ASSERT_TRUE(fov_truth.ok() && fov.ok());
  std::printf(
      "end to end: projection diff %.4f px RMS (max %.4f) over the central 80%%; "
      "FOV %.3f x %.3f (truth %.3f x %.3f) deg, diagonal %.3f (truth %.3f); fx %.3f (truth %.3f)\n",
      diff->rms_px, diff->max_px, fov->horizontal_deg, fov->vertical_deg, fov_truth->horizontal_deg,
      fov_truth->vertical_deg, fov->diagonal_deg, fov_truth->diagonal_deg, fitted.intrinsics[0],
      truth.intrinsics[0]);
  EXPECT_LE(diff->rms_px, 0.2);
  EXPECT_NEAR(fov->horizontal_deg, fov_truth->horizontal_deg, 0.2);
  EXPECT_NEAR(fov->vertical_deg, fov_truth->vertical_deg, 0.2);

  std::ifstream report_file(dir / "report.json");
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_GE(report["views"]["used"].get<int>(), 8);
  EXPECT_LT(report["residuals"]["rms_px"].get<double>(), 0.2);
  EXPECT_NEAR(report["focal_mm"].get<double>(), truth.intrinsics[0] * 0.003, 0.005);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace camlab::calib
