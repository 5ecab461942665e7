// Hard calibration cases (docs/measuring.md): each must give the right answer or a specific
// warning, never NaN and never a silent wrong number. Synthetic corners from a known lens
// (mrcal's testing style): fixed-seed poses and Gaussian noise.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "calib/lens_model.h"
#include "calib/report.h"
#include "calib/solver.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

const BoardSpec kBoard{14, 10, 0.04};

void expect_finite(const Solution& s) {
  for (double v : s.model.intrinsics) EXPECT_TRUE(std::isfinite(v));
  EXPECT_TRUE(std::isfinite(s.rms_px));
  for (const auto& rt : s.rt_cam_board)
    for (double v : rt) EXPECT_TRUE(std::isfinite(v));
}

// Right answer: projection within `px` RMS of the truth over the central 80%, FOV within
// 0.2 deg.
void expect_right(const LensModel& truth, const Solution& s, double px) {
  auto d = projection_difference(truth, s.model, 0.8);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_LT(d->rms_px, px);
  auto ft = field_of_view(truth);
  auto f = field_of_view(s.model);
  ASSERT_TRUE(ft.ok() && f.ok());
  EXPECT_NEAR(f->horizontal_deg, ft->horizontal_deg, 0.2);
  EXPECT_NEAR(f->vertical_deg, ft->vertical_deg, 0.2);
}

bool right_answer(const LensModel& truth, const Solution& s, double px) {
  auto d = projection_difference(truth, s.model, 0.8);
  auto ft = field_of_view(truth);
  auto f = field_of_view(s.model);
  return d.ok() && ft.ok() && f.ok() && d->rms_px < px &&
         std::fabs(f->horizontal_deg - ft->horizontal_deg) < 0.2;
}

SolveOptions opencv8() {
  SolveOptions o;
  o.lensmodel = "LENSMODEL_OPENCV8";
  return o;
}

// The report of a solve of views of the wide OPENCV8 truth made to `spec` with
// `lensmodel`; the solve must succeed with finite numbers (nullopt after a failure).
std::optional<CalibrationReport> report_for(const testing::ViewSetSpec& spec,
                                            const std::string& lensmodel = "LENSMODEL_OPENCV8") {
  const auto data = testing::make_views(testing::wide_opencv8_truth(), kBoard, spec);
  SolveOptions options;
  options.lensmodel = lensmodel;
  auto s = solve(data, options);
  EXPECT_TRUE(s.ok()) << s.error().message;
  if (!s.ok()) return std::nullopt;
  expect_finite(*s);
  return make_report(data, *s, 0);
}

bool warns(const testing::ViewSetSpec& spec, const std::string& code,
           const std::string& lensmodel = "LENSMODEL_OPENCV8") {
  const auto report = report_for(spec, lensmodel);
  return report && has_warning(*report, code);
}

TEST(CalibStability, FrontoParallelBoardsWarn) {
  testing::ViewSetSpec spec;
  spec.views = 20;
  spec.max_tilt_deg = 3;
  spec.noise_px = 0.1;
  EXPECT_TRUE(warns(spec, "fronto_parallel", "LENSMODEL_OPENCV4"));
}

TEST(CalibStability, TiltedBoardsDoNotWarnFrontoParallel) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 20;
  spec.noise_px = 0.1;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto s = solve(data, opencv8());
  ASSERT_TRUE(s.ok()) << s.error().message;
  const auto report = make_report(data, *s, 0);
  EXPECT_FALSE(has_warning(report, "fronto_parallel"));
  EXPECT_FALSE(has_warning(report, "too_few_views"));
  EXPECT_FALSE(has_warning(report, "many_outliers"));
  expect_right(truth, *s, 0.2);
}

// The projection uncertainty (calib/uncertainty.h) says where the data cannot support the
// model: corners that hold no board (centre-only views) are far less certain than with
// boards reaching the edges, at the same noise; never NaN.
TEST(CalibStability, UncertaintyGrowsWhereTheBoardsDidNotReach) {
  const LensModel truth = testing::wide_opencv8_truth();
  auto corner_uncertainty = [&](double centre_fraction, double distance_min_m) {
    testing::ViewSetSpec spec;
    spec.views = 20;
    spec.noise_px = 0.1;
    spec.centre_fraction = centre_fraction;
    spec.distance_min_m = distance_min_m;
    spec.distance_max_m = distance_min_m + 0.4;
    const auto data = testing::make_views(truth, kBoard, spec);
    auto s = solve(data, opencv8());
    EXPECT_TRUE(s.ok());
    const auto report = make_report(data, *s, 0);
    EXPECT_TRUE(report.uncertainty.has_value()) << report.uncertainty_error;
    if (!report.uncertainty) return std::pair<double, double>{0, 0};
    double worst_corner = 0;
    for (const auto& p : report.uncertainty->points) {
      if (!p.at_infinity_px) continue;
      EXPECT_TRUE(std::isfinite(*p.at_infinity_px));
      if (p.where != "centre") worst_corner = std::max(worst_corner, *p.at_infinity_px);
    }
    return std::pair{*report.uncertainty->points[0].at_infinity_px, worst_corner};
  };
  const auto [good_centre, good_corner] = corner_uncertainty(0.9, 0.4);
  const auto [centre_only_centre, centre_only_corner] = corner_uncertainty(0.1, 1.0);
  std::printf(
      "uncertainty at infinity: spread boards centre %.4f corner %.3f px; centre-only centre %.4f "
      "corner %.3f px\n",
      good_centre, good_corner, centre_only_centre, centre_only_corner);
  EXPECT_LT(good_centre, 0.1);
  EXPECT_GT(centre_only_corner, 5 * good_corner);
}

class FewViews : public ::testing::TestWithParam<int> {};

TEST_P(FewViews, RightOrWarnedNeverNan) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = GetParam();
  spec.noise_px = 0.1;
  spec.seed = 7;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto s = solve(data, opencv8());
  ASSERT_TRUE(s.ok()) << s.error().message;
  expect_finite(*s);
  const auto report = make_report(data, *s, 0);
  EXPECT_TRUE(has_warning(report, "too_few_views"));
  // Even the warned solution must not be wildly off: fx within 5% of the truth.
  EXPECT_NEAR(s->model.intrinsics[0], truth.intrinsics[0], 0.05 * truth.intrinsics[0]);
}

INSTANTIATE_TEST_SUITE_P(CalibStability, FewViews, ::testing::Values(3, 5));

TEST(CalibStability, FarBoardsWarn) {
  testing::ViewSetSpec spec;
  spec.views = 20;
  spec.distance_min_m = 3;
  spec.distance_max_m = 5;
  spec.noise_px = 0.1;
  EXPECT_TRUE(warns(spec, "far_boards"));
}

TEST(CalibStability, CentreOnlyBoardsWarn) {
  testing::ViewSetSpec spec;
  spec.views = 20;
  spec.centre_fraction = 0.1;
  spec.distance_min_m = 1.0;
  spec.distance_max_m = 1.4;
  spec.noise_px = 0.1;
  EXPECT_TRUE(warns(spec, "centre_only"));
}

TEST(CalibStability, TwoPercentGrossOutliersAreRejected) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 25;
  spec.noise_px = 0.1;
  spec.outlier_share = 0.02;
  spec.seed = 3;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto s = solve(data, opencv8());
  ASSERT_TRUE(s.ok()) << s.error().message;
  expect_finite(*s);
  const double share = double(s->outliers) / (s->inliers + s->outliers);
  EXPECT_GT(share, 0.015);
  EXPECT_LT(share, 0.04);  // the gross ones, not the good corners
  EXPECT_LT(s->rms_px, 0.2);
  expect_right(truth, *s, 0.15);
  EXPECT_FALSE(has_warning(make_report(data, *s, 0), "many_outliers"));
}

TEST(CalibStability, ManyOutliersWarn) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 20;
  spec.noise_px = 0.1;
  spec.outlier_share = 0.12;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto s = solve(data, opencv8());
  ASSERT_TRUE(s.ok()) << s.error().message;
  expect_finite(*s);
  const auto report = make_report(data, *s, 0);
  EXPECT_TRUE(has_warning(report, "many_outliers") || right_answer(truth, *s, 0.2));
  EXPECT_TRUE(has_warning(report, "many_outliers"));
}

TEST(CalibStability, PartialBoardsInManyViews) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 30;
  spec.centre_fraction = 1.3;  // board centres aimed up to 15% beyond the imager edges
  spec.noise_px = 0.1;
  spec.seed = 11;
  const auto data = testing::make_views(truth, kBoard, spec);
  int partial = 0;
  for (const auto& v : data.views) partial += v.present_count() < kBoard.cols * kBoard.rows;
  ASSERT_GE(partial, 10);
  auto s = solve(data, opencv8());
  ASSERT_TRUE(s.ok()) << s.error().message;
  // Missing corners never enter the seed; good corners are not thrown away.
  EXPECT_LT(double(s->outliers) / (s->inliers + s->outliers), 0.01);
  expect_right(truth, *s, 0.15);
}

class FocalGuess : public ::testing::TestWithParam<double> {};

TEST_P(FocalGuess, WrongGuessStillConverges) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 20;
  spec.noise_px = 0.1;
  spec.seed = 5;
  const auto data = testing::make_views(truth, kBoard, spec);
  SolveOptions o = opencv8();
  o.focal_guess_px = truth.intrinsics[0] * GetParam();
  auto s = solve(data, o);
  ASSERT_TRUE(s.ok()) << s.error().message;
  expect_right(truth, *s, 0.2);
}

INSTANTIATE_TEST_SUITE_P(CalibStability, FocalGuess, ::testing::Values(0.1, 0.5, 2.0, 10.0));

TEST(CalibStability, Lens120DegreesStereographic) {
  // A 120-degree (horizontal) stereographic lens: q = 2 f tan(theta / 2), 640 px at 60 deg.
  const double f = 640.0 / (2 * std::tan(M_PI / 6));
  const LensModel truth{"LENSMODEL_STEREOGRAPHIC", {f, f, 641.2, 399.1}, 1280, 800};
  testing::ViewSetSpec spec;
  spec.views = 30;
  spec.noise_px = 0.1;
  spec.distance_min_m = 0.3;
  spec.distance_max_m = 0.8;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto fov = field_of_view(truth);
  ASSERT_TRUE(fov.ok());
  ASSERT_NEAR(fov->horizontal_deg, 120.0, 0.2);
  // OPENCV8 (rational) must follow it over the central 80% of the imager.
  auto s = solve(data, opencv8());
  ASSERT_TRUE(s.ok()) << s.error().message;
  expect_finite(*s);
  const auto report = make_report(data, *s, 0);
  auto d = projection_difference(truth, s->model, 0.8);
  std::printf("120-deg lens, OPENCV8 fit: rms %.3f px, projection diff %.3f px, warnings %zu\n",
              s->rms_px, d.ok() ? d->rms_px : -1.0, report.warnings.size());
  expect_right(truth, *s, 0.2);
  EXPECT_TRUE(report.warnings.empty());
  SolveOptions o;
  o.lensmodel = "LENSMODEL_STEREOGRAPHIC";
  auto exact = solve(data, o);
  ASSERT_TRUE(exact.ok()) << exact.error().message;
  expect_right(truth, *exact, 0.1);
}

TEST(CalibStability, SplinedStereographicFollowsTheWideLens) {
  // The splined model (16 x 10 knots over 115 deg) from a stereographic core: no
  // parametric assumption about the lens, regularized where the data are thin.
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 25;
  spec.noise_px = 0.1;
  spec.centre_fraction = 1.1;
  spec.seed = 21;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto name = configured_lensmodel("SPLINED_STEREOGRAPHIC", 1280, 800, 103.2);
  ASSERT_TRUE(name.ok());
  SolveOptions o;
  o.lensmodel = *name;
  auto s = solve(data, o);
  ASSERT_TRUE(s.ok()) << s.error().message;
  expect_finite(*s);
  EXPECT_LT(s->rms_px, 0.16);
  auto d = projection_difference(truth, s->model, 0.8);
  ASSERT_TRUE(d.ok());
  std::printf("splined: rms %.4f px, diff %.4f px, %.2f s\n", s->rms_px, d->rms_px, s->solve_s);
  expect_right(truth, *s, 0.15);
}

}  // namespace
}  // namespace camlab::calib
