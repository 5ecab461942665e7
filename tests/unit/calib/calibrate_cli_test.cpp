// `camlab calibrate` end to end from corners.vnl: the files it writes load in mrcal and
// OpenCV and hold the truth's lens; bad input ends with "camlab calibrate: ..." and code 2.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/corners/corners_vnl.h"
#include "calib/mrcal_api.h"
#include "synthetic_views.h"
#include "tests/integration/cli_runner.h"

namespace camlab::calib {
namespace {

namespace fs = std::filesystem;

class CalibrateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("camlab_calib_cli_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST_F(CalibrateCli, CornersVnlToCameramodelYamlAndReport) {
  const LensModel truth{
      "LENSMODEL_OPENCV5", {1100, 1100, 962, 541, -0.3, 0.1, 0.0003, -0.0002, -0.01}, 1920, 1080};
  testing::ViewSetSpec spec;
  spec.views = 16;
  spec.noise_px = 0.15;
  const auto data = testing::make_views(truth, BoardSpec{9, 6, 0.06}, spec);
  {
    std::ofstream out(path("corners.vnl"));
    out << to_corners_vnl(data.views);
  }
  const auto run = camlab::testing::run_cli("calibrate --corners " + path("corners.vnl") +
                                            " --imager 1920x1080 --board 9x6 --spacing-m 0.06"
                                            " --model LENSMODEL_OPENCV5 --sensor 1/2.3in --out " +
                                            path("cam.cameramodel") + " --opencv-yaml " +
                                            path("cam.yaml") + " --report " + path("report.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("FOV (unprojected image edges)"), std::string::npos) << run.out;

  mrcal_cameramodel_t* model = mrcal_read_cameramodel_file(path("cam.cameramodel").c_str());
  ASSERT_NE(model, nullptr);
  const LensModel fitted{"LENSMODEL_OPENCV5",
                         std::vector<double>(model->intrinsics, model->intrinsics + 9), 1920, 1080};
  EXPECT_EQ(model->imagersize[0], 1920u);
  mrcal_free_cameramodel(&model);
  auto d = projection_difference(truth, fitted, 0.8);
  ASSERT_TRUE(d.ok());
  EXPECT_LT(d->rms_px, 0.2);

  cv::FileStorage yaml(path("cam.yaml"), cv::FileStorage::READ);
  cv::Mat K;
  yaml["camera_matrix"] >> K;
  ASSERT_EQ(K.rows, 3);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 0), fitted.intrinsics[0]);

  std::ifstream report_file(path("report.json"));
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_EQ(report["lensmodel"], "LENSMODEL_OPENCV5");
  const auto fov_truth = field_of_view(truth);
  ASSERT_TRUE(fov_truth.ok());
  EXPECT_NEAR(report["fov_deg"]["horizontal"].get<double>(), fov_truth->horizontal_deg, 0.2);
  // 1/2.3": 6.16 mm over 1920 px -> 3.208 um; f = 1100 px x 3.208 um = 3.529 mm.
  EXPECT_NEAR(report["pixel_pitch_um"].get<double>(), 6.16 / 1920 * 1000, 1e-9);
  EXPECT_NEAR(report["focal_mm"].get<double>(), 1100 * 6.16 / 1920, 0.01);
  EXPECT_NEAR(report["focal_35mm_equiv_mm"].get<double>(),
              1100 * 6.16 / 1920 * 43.266615305567875 / std::hypot(6.16, 1080 * 6.16 / 1920), 0.1);
  EXPECT_TRUE(report["warnings"].is_array());
}

TEST_F(CalibrateCli, AutoPrintsTheEvidenceTable) {
  const LensModel truth{"LENSMODEL_OPENCV4", {900, 900, 640, 480, -0.2, 0.05, 0, 0}, 1280, 960};
  testing::ViewSetSpec spec;
  spec.views = 12;
  spec.noise_px = 0.2;
  const auto data = testing::make_views(truth, BoardSpec{8, 6, 0.05}, spec);
  {
    std::ofstream out(path("corners.vnl"));
    out << to_corners_vnl(data.views);
  }
  const auto run = camlab::testing::run_cli("calibrate --corners " + path("corners.vnl") +
                                            " --imager 1280x960 --board 8x6 --spacing-m 0.05"
                                            " --out " +
                                            path("cam.cameramodel") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  ASSERT_GE(j["model_selection"].size(), 3u);
  EXPECT_EQ(j["model_selection"][0]["lensmodel"], "LENSMODEL_PINHOLE");
  EXPECT_EQ(j["lensmodel"], "LENSMODEL_OPENCV4");
}

// mrcal's C library prints each outlier-rejection round on stderr ("Threw out some outliers
// ... going again"); camlab routes those lines into its log at debug level, so the user's
// stderr holds camlab's own lines only, and CAMLAB_LOG=calib=debug shows mrcal's.
TEST_F(CalibrateCli, StderrHoldsCamlabsOwnOutputOnlyAndMrcalsLinesGoToTheDebugLog) {
  testing::ViewSetSpec spec;
  spec.views = 20;
  spec.noise_px = 0.2;
  spec.outlier_share = 0.03;  // rejected in several rounds: mrcal prints each
  const auto data =
      testing::make_views(testing::wide_opencv8_truth(), BoardSpec{10, 8, 0.04}, spec);
  {
    std::ofstream out(path("corners.vnl"));
    out << to_corners_vnl(data.views);
  }
  const std::string args = "calibrate --corners " + path("corners.vnl") +
                           " --imager 1280x800 --board 10x8 --spacing-m 0.04"
                           " --model LENSMODEL_OPENCV8 --out " +
                           path("cam.cameramodel");
  auto run = camlab::testing::run_cli(args);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::istringstream lines(run.err);
  for (std::string line; std::getline(lines, line);)
    EXPECT_EQ(line.rfind("camlab ", 0), 0u) << "not camlab's: " << line;
  EXPECT_EQ(run.err.find("mrcal.c"), std::string::npos) << run.err;

  ASSERT_EQ(setenv("CAMLAB_LOG", "calib=debug", 1), 0);
  run = camlab::testing::run_cli(args);
  unsetenv("CAMLAB_LOG");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("debug calib: mrcal: mrcal.c("), std::string::npos)
      << "mrcal's lines were dropped, not logged:\n"
      << run.err.substr(0, 2000);
  EXPECT_NE(run.err.find("Threw out some outliers"), std::string::npos);
  std::istringstream debug_lines(run.err);
  for (std::string line; std::getline(debug_lines, line);)
    EXPECT_EQ(line.rfind("camlab ", 0), 0u) << "not camlab's: " << line;
}

TEST_F(CalibrateCli, BadInputFailsWithCode2AndAMessage) {
  auto run = camlab::testing::run_cli(
      "calibrate --corners /nonexistent.vnl --imager 640x480 --board 9x6 "
      "--spacing-m 0.05 --out " +
      path("x.cameramodel"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("camlab calibrate: cannot read '/nonexistent.vnl'"), std::string::npos)
      << run.err;
  run = camlab::testing::run_cli("calibrate --corners a.vnl --board 9 --spacing-m 0.05 --out " +
                                 path("x.cameramodel"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--board must be COLSxROWS"), std::string::npos) << run.err;
  {
    std::ofstream out(path("c.vnl"));
    out << "# filename x y level\n";
  }
  run = camlab::testing::run_cli("calibrate --corners " + path("c.vnl") +
                                 " --board 9x6 --spacing-m 0.05 --out " + path("x.cameramodel"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--imager"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(path("x.cameramodel")));
  // A ChArUco board needs its markers, and they must fit it; markers without the
  // ChArUco detector are a mistake, not ignored.
  const std::string images = " --images " + dir_.string() + " --out " + path("x.cameramodel");
  run = camlab::testing::run_cli("calibrate --board 10x7 --spacing-m 0.06 --detector charuco" +
                                 images);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--detector charuco needs the board's markers: --marker-m and "
                         "--dictionary"),
            std::string::npos)
      << run.err;
  run = camlab::testing::run_cli(
      "calibrate --board 10x7 --spacing-m 0.06 --detector charuco --marker-m 0.07 "
      "--dictionary DICT_4X4_50" +
      images);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("smaller than the square"), std::string::npos) << run.err;
  run = camlab::testing::run_cli(
      "calibrate --board 11x8 --spacing-m 0.06 --detector charuco --marker-m 0.045 "
      "--dictionary DICT_4X4_50" +
      images);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("needs 54 markers; DICT_4X4_50 has 50"), std::string::npos) << run.err;
  run = camlab::testing::run_cli(
      "calibrate --board 10x7 --spacing-m 0.06 --detector charuco --marker-m 0.045 "
      "--dictionary DICT_4X4_5" +
      images);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("unknown ArUco dictionary \"DICT_4X4_5\""), std::string::npos) << run.err;
  run =
      camlab::testing::run_cli("calibrate --board 10x7 --spacing-m 0.06 --marker-m 0.045" + images);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("add --detector charuco"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(path("x.cameramodel")));
}

// Renders a chessboard (cols x rows inner corners, white margin of one square) through a
// pinhole camera, 4 x 4 supersampled: enough for OpenCV's detector to find sub-pixel
// corners.
cv::Mat draw_board(const LensModel& pinhole, const BoardSpec& b, const std::array<double, 6>& rt) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), R);
  const cv::Vec3d t(rt[3], rt[4], rt[5]);
  // Board plane z = 0: a pixel's ray meets it at the board point (u, v).
  const cv::Vec3d n(R(0, 2), R(1, 2), R(2, 2));
  cv::Mat img(pinhole.height_px, pinhole.width_px, CV_8UC1);
  const double fx = pinhole.intrinsics[0], fy = pinhole.intrinsics[1];
  const double cx = pinhole.intrinsics[2], cy = pinhole.intrinsics[3];
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      int sum = 0;
      for (int sy = 0; sy < 4; ++sy)
        for (int sx = 0; sx < 4; ++sx) {
          const cv::Vec3d d((x - 0.375 + 0.25 * sx - cx) / fx, (y - 0.375 + 0.25 * sy - cy) / fy,
                            1);
          const double s = n.dot(t) / n.dot(d);
          const cv::Vec3d pb = R.t() * (d * s - t);
          // Square (i, j) spans [(i - 1) s, i s): corner (0, 0) of the inner grid at 0.
          const double u = pb[0] / b.spacing_m + 1, v = pb[1] / b.spacing_m + 1;
          const bool on_board = u >= -1 && v >= -1 && u < b.cols + 2 && v < b.rows + 2;
          const bool squares = u >= 0 && v >= 0 && u < b.cols + 1 && v < b.rows + 1;
          int value = on_board ? 230 : 120;
          if (squares &&
              ((static_cast<int>(std::floor(u)) + static_cast<int>(std::floor(v))) % 2 == 0))
            value = 25;
          sum += value;
        }
      img.at<uint8_t>(y, x) = static_cast<uint8_t>(sum / 16);
    }
  return img;
}

TEST_F(CalibrateCli, ImagesFolderThroughOpencvCorners) {
  const LensModel truth{"LENSMODEL_PINHOLE", {600, 600, 319.5, 239.5}, 640, 480};
  const BoardSpec board{7, 5, 0.03};
  fs::create_directories(dir_ / "images");
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 6; ++i) {
    const cv::Vec3d centre(0.04 * u(rng), 0.03 * u(rng), 0.32 + 0.05 * u(rng));
    const auto rt = testing::pose_facing(centre, 0.5 * u(rng), 0.5 * u(rng), 0.2 * u(rng), board);
    cv::imwrite((dir_ / "images" / ("view" + std::to_string(i) + ".png")).string(),
                draw_board(truth, board, rt));
  }
  const auto run =
      camlab::testing::run_cli("calibrate --images " + path("images") +
                               " --board 7x5 --spacing-m 0.03 --model LENSMODEL_PINHOLE"
                               " --detector opencv"
                               " --quiet --json --out " +
                               path("cam.cameramodel"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["views"]["used"].get<int>(), 6);
  EXPECT_EQ(j["imagersize"][0].get<int>(), 640);
  EXPECT_NEAR(j["fx_px"].get<double>(), 600, 3);
  EXPECT_NEAR(j["cx_px"].get<double>(), 319.5, 3);
  EXPECT_LT(j["residuals"]["rms_px"].get<double>(), 0.1);
  // Six views are flagged, whatever their fit.
  bool too_few = false;
  for (const auto& w : j["warnings"]) too_few |= w["code"] == "too_few_views";
  EXPECT_TRUE(too_few);
}

}  // namespace
}  // namespace camlab::calib
