// The staged mrcal solve against synthetic truth (mrcal's testing style: known model,
// fixed-seed poses and noise).
#include <cmath>

#include <gtest/gtest.h>

#include "calib/lens_model.h"
#include "calib/report.h"
#include "calib/solver.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace calib_solve_test {

const BoardSpec kBoard{14, 10, 0.04};

TEST(CalibSolve, WideOpencv8RecoversTheTruthByProjection) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 30;
  spec.noise_px = 0.1;
  const CalibrationData data = testing::make_views(truth, kBoard, spec);
  ASSERT_EQ(data.views.size(), 30u);
  SolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV8";
  auto s = solve(data, options);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->views_used.size(), 30u);
  // Residuals at the noise level: sqrt(2) * 0.2 px for 2-D Gaussian noise.
  EXPECT_NEAR(s->rms_px, 0.1 * std::sqrt(2.0), 0.015);
  EXPECT_LT(s->outliers, s->inliers / 100);
  auto diff = projection_difference(truth, s->model, 0.8);
  ASSERT_TRUE(diff.ok());
  EXPECT_LT(diff->rms_px, 0.15);
  auto fov_truth = field_of_view(truth);
  auto fov = field_of_view(s->model);
  ASSERT_TRUE(fov_truth.ok() && fov.ok());
  EXPECT_NEAR(fov->horizontal_deg, fov_truth->horizontal_deg, 0.2);
  EXPECT_NEAR(fov->vertical_deg, fov_truth->vertical_deg, 0.2);
  EXPECT_NEAR(fov->diagonal_deg, fov_truth->diagonal_deg, 0.3);
  std::printf(
      "seed %s f=%.1f  fx=%.3f fy=%.3f cx=%.3f cy=%.3f rms=%.4f diff=%.4f (max %.4f) hfov "
      "%.3f/%.3f time %.3f s\n",
      s->seed_projection.c_str(), s->seed_focal_px, s->model.intrinsics[0], s->model.intrinsics[1],
      s->model.intrinsics[2], s->model.intrinsics[3], s->rms_px, diff->rms_px, diff->max_px,
      fov->horizontal_deg, fov_truth->horizontal_deg, s->solve_s);
}

TEST(CalibReport, ImplausibleIntrinsicsAreWarnedNotPassedOff) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 12;
  const CalibrationData data = testing::make_views(truth, kBoard, spec);
  SolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV4";
  options.compute_covariance = false;
  auto s = solve(data, options);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_FALSE(has_warning(make_report(data, *s, 0), "implausible_intrinsics"));
  // What a wrong --board gave camlabd once: fx/fy in the thousands, the centre off the imager.
  Solution stretched = *s;
  stretched.model.intrinsics[1] = stretched.model.intrinsics[0] / 3;
  EXPECT_TRUE(has_warning(make_report(data, stretched, 0), "implausible_intrinsics"));
  Solution off_centre = *s;
  off_centre.model.intrinsics[3] = 2.0 * truth.height_px;
  EXPECT_TRUE(has_warning(make_report(data, off_centre, 0), "implausible_intrinsics"));
}

// A model that folds over only in the image corners (lens_model_test.cpp) still has a
// horizontal and a vertical FOV: the report gives them, the diagonal as null, and the
// warning says it is the diagonal that is missing.
TEST(CalibReport, FovWhereDefinedAndTheWarningNamesTheMissingOne) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 8;
  const CalibrationData data = testing::make_views(truth, kBoard, spec);
  SolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV4";
  options.compute_covariance = false;
  auto s = solve(data, options);
  ASSERT_TRUE(s.ok()) << s.error().message;
  Solution folding = *s;
  folding.model.intrinsics = {800, 800, 639.5, 399.5, 0, -0.143, 0, 0};
  const CalibrationReport r = make_report(data, folding, 0);
  ASSERT_TRUE(r.fov.horizontal_deg && r.fov.vertical_deg);
  EXPECT_FALSE(r.fov.diagonal_deg);
  const auto j = to_json(r);
  EXPECT_TRUE(j["fov_deg"]["horizontal"].is_number());
  EXPECT_TRUE(j["fov_deg"]["vertical"].is_number());
  EXPECT_TRUE(j["fov_deg"]["diagonal"].is_null());
  ASSERT_TRUE(has_warning(r, "fov_undefined"));
  for (const auto& w : r.warnings)
    if (w.code == "fov_undefined") {
      EXPECT_NE(w.message.find("diagonal FOV is undefined"), std::string::npos) << w.message;
      EXPECT_EQ(w.message.find("horizontal FOV is"), std::string::npos) << w.message;
    }
  EXPECT_NE(to_text(r).find("diagonal undefined"), std::string::npos) << to_text(r);
  // With the full model: no warning, all three.
  const CalibrationReport whole = make_report(data, *s, 0);
  EXPECT_TRUE(whole.fov.all());
  EXPECT_FALSE(has_warning(whole, "fov_undefined"));
}

}  // namespace calib_solve_test
}  // namespace
}  // namespace camlab::calib
