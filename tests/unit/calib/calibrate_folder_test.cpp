// calib::calibrate_folder (calib/calibrate.h), the entry point the daemon's
// POST /v1/calibrations calls: outputs written where asked, the report JSON with the
// projection uncertainty, the plots, and model selection with fewer than 6 views.
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/calibrate.h"
#include "calib/corners/corners_vnl.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

namespace fs = std::filesystem;

class CalibrateFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("camlab_calibrate_folder_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Synthetic corners of the wide OPENCV8 lens written as corners.vnl.
  CalibrateOptions corners_options(int views, uint32_t seed) {
    const LensModel truth = testing::wide_opencv8_truth();
    testing::ViewSetSpec spec;
    spec.views = views;
    spec.noise_px = 0.15;
    spec.seed = seed;
    const BoardSpec board{10, 7, 0.05};
    const auto data = testing::make_views(truth, board, spec);
    std::ofstream(dir_ / "corners.vnl") << to_corners_vnl(data.views);
    CalibrateOptions o;
    o.corners_vnl = dir_ / "corners.vnl";
    o.board = board;
    o.imager_width_px = truth.width_px;
    o.imager_height_px = truth.height_px;
    return o;
  }

  fs::path dir_;
};

TEST_F(CalibrateFolder, WritesTheOutputsAndReportsTheUncertainty) {
  CalibrateOptions o = corners_options(16, 3);
  o.model = "LENSMODEL_OPENCV8";
  o.out_cameramodel = dir_ / "cam.cameramodel";
  o.out_report_json = dir_ / "report.json";
  o.out_opencv_yaml = dir_ / "cam.yaml";
  o.plots_dir = dir_ / "plots";
  auto j = calibrate_folder(o);
  ASSERT_TRUE(j.ok()) << j.error().message;
  EXPECT_EQ((*j)["lensmodel"], "LENSMODEL_OPENCV8");
  for (const auto& f : {o.out_cameramodel, o.out_report_json, o.out_opencv_yaml})
    EXPECT_TRUE(fs::exists(f)) << f;
  std::ifstream in(o.out_report_json);
  EXPECT_EQ(nlohmann::json::parse(in), *j);
  // The uncertainty at the five points; corners (extrapolated) above the centre.
  const auto& u = (*j)["projection_uncertainty"];
  ASSERT_TRUE(u.contains("points")) << u.dump();
  ASSERT_EQ(u["points"].size(), 5u);
  EXPECT_EQ(u["points"][0]["where"], "centre");
  EXPECT_NEAR(u["observed_sigma_px"].get<double>(), 0.15, 0.02);
  const double centre = u["points"][0]["at_infinity_px"].get<double>();
  EXPECT_GT(centre, 0.0);
  EXPECT_LT(centre, 0.15);
  // Six plots, each a readable image of the requested size.
  ASSERT_EQ((*j)["files"]["plots"].size(), 6u) << j->dump();
  for (const char* name : {"residuals.png", "residuals_per_view.png", "residual_histogram.png",
                           "coverage.png", "uncertainty.png", "distortion.png"}) {
    const cv::Mat img = cv::imread((o.plots_dir / name).string());
    ASSERT_FALSE(img.empty()) << name;
    EXPECT_GE(img.cols, 640) << name;
  }
}

TEST_F(CalibrateFolder, FewViewsHoldOutCornersAndSayItInTheReport) {
  CalibrateOptions o = corners_options(5, 8);
  auto run = calibrate(o);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->report_json["cross_validation"], "corners");
  // The held-out error is its own number, not the fit's RMS, and it exposes the pinhole
  // model on a wide lens.
  const auto& ev = run->report_json["model_selection"];
  ASSERT_GE(ev.size(), 2u);
  for (const auto& row : ev) {
    if (!row["ok"].get<bool>()) continue;
    EXPECT_NE(row["heldout_px"].get<double>(), row["rms_px"].get<double>()) << row.dump();
    EXPECT_GE(row["heldout_px"].get<double>(), 0.8 * row["rms_px"].get<double>()) << row.dump();
  }
  EXPECT_NE(run->report_json["lensmodel"], "LENSMODEL_PINHOLE");
  bool too_few = false;
  for (const auto& w : run->report_json["warnings"]) too_few |= w["code"] == "too_few_views";
  EXPECT_TRUE(too_few);
  EXPECT_NE(to_text(run->report).find("every third corner left out"), std::string::npos);
}

TEST_F(CalibrateFolder, BadOptionsAreErrorsWithStableCodes) {
  CalibrateOptions o;
  auto r = calibrate_folder(o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "invalid_argument");
  o = corners_options(8, 1);
  o.imager_width_px = 0;
  o.imager_height_px = 0;
  r = calibrate_folder(o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "invalid_argument");
  o = corners_options(8, 1);
  o.images_dir = dir_;  // two sources
  EXPECT_EQ(calibrate_folder(o).error().code, "invalid_argument");
}

}  // namespace
}  // namespace camlab::calib
