// `--model auto`: the simplest model the held-out views support, chosen by projection.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "calib/lens_model.h"
#include "calib/model_selection.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace model_selection_test {

const BoardSpec kBoard{10, 7, 0.05};

const ModelEvidence* find(const ModelSelection& sel, const std::string& name) {
  for (const auto& e : sel.evidence)
    if (e.lensmodel == name) return &e;
  return nullptr;
}

TEST(ModelSelection, PinholeLensKeepsPinhole) {
  const LensModel truth{"LENSMODEL_PINHOLE", {1500, 1500, 815.5, 607.25}, 1600, 1200};
  testing::ViewSetSpec spec;
  spec.views = 18;
  spec.noise_px = 0.2;
  spec.distance_min_m = 0.8;
  spec.distance_max_m = 1.5;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto sel = select_model(data, SolveOptions{}, default_candidate_models());
  ASSERT_TRUE(sel.ok()) << sel.error().message;
  EXPECT_EQ(sel->chosen.model.lensmodel, "LENSMODEL_PINHOLE");
  // Richer models do not beat it on held-out views (they fit the noise).
  const auto* pinhole = find(*sel, "LENSMODEL_PINHOLE");
  const auto* opencv4 = find(*sel, "LENSMODEL_OPENCV4");
  ASSERT_TRUE(pinhole && opencv4 && pinhole->ok && opencv4->ok);
  EXPECT_GT(opencv4->heldout_px, 0.95 * pinhole->heldout_px - 0.005);
  EXPECT_NEAR(sel->chosen.model.intrinsics[0], 1500, 3);
}

TEST(ModelSelection, BarrelLensPicksOpencv4AndStops) {
  const LensModel truth{
      "LENSMODEL_OPENCV4", {1000, 1000, 805, 598, -0.25, 0.08, 0.0005, -0.0004}, 1600, 1200};
  testing::ViewSetSpec spec;
  spec.views = 18;
  spec.noise_px = 0.2;
  const auto data = testing::make_views(truth, kBoard, spec);
  auto sel = select_model(data, SolveOptions{}, default_candidate_models());
  ASSERT_TRUE(sel.ok()) << sel.error().message;
  EXPECT_EQ(sel->chosen.model.lensmodel, "LENSMODEL_OPENCV4");
  const auto* pinhole = find(*sel, "LENSMODEL_PINHOLE");
  ASSERT_TRUE(pinhole && pinhole->ok);
  EXPECT_GT(pinhole->heldout_px, 3 * sel->chosen.rms_px);  // distortion is real
  auto d = projection_difference(truth, sel->chosen.model, 0.8);
  ASSERT_TRUE(d.ok());
  std::printf("barrel: chosen %s diff %.3f px rms %.3f\n", sel->chosen.model.lensmodel.c_str(),
              d->rms_px, sel->chosen.rms_px);
  for (double v : sel->chosen.model.intrinsics) std::printf(" %.5g", v);
  std::printf("\n");
  EXPECT_LT(d->rms_px, 0.2);
  // Two richer models without gain end the search: OPENCV12 is never fitted.
  EXPECT_EQ(find(*sel, "LENSMODEL_OPENCV12"), nullptr);
}

TEST(ModelSelection, WideLensNeedsMoreThanOpencv4) {
  const LensModel truth = testing::wide_opencv8_truth();
  testing::ViewSetSpec spec;
  spec.views = 14;
  spec.noise_px = 0.15;
  const auto data = testing::make_views(truth, BoardSpec{14, 10, 0.04}, spec);
  auto sel = select_model(data, SolveOptions{}, default_candidate_models());
  ASSERT_TRUE(sel.ok()) << sel.error().message;
  const std::string& chosen = sel->chosen.model.lensmodel;
  // The held-out views reject the models without enough radial terms.
  EXPECT_NE(chosen, "LENSMODEL_PINHOLE");
  EXPECT_NE(chosen, "LENSMODEL_OPENCV4");
  auto d = projection_difference(truth, sel->chosen.model, 0.8);
  ASSERT_TRUE(d.ok());
  EXPECT_LT(d->rms_px, 0.2);
  for (const auto& e : sel->evidence) {
    if (!e.ok) continue;
    std::printf("  %-20s %3d params rms %.4f heldout %.4f solve %.3f s\n", e.lensmodel.c_str(),
                e.params, e.rms_px, e.heldout_px, e.solve_s);
  }
}

// Views of a wide lens: boards 0.25-0.6 m away, aimed across `centre_fraction` of the
// imager, 0.2 px noise; the evidence table printed.
CalibrationData wide_lens_views(const LensModel& truth, int views, double centre_fraction) {
  testing::ViewSetSpec spec;
  spec.views = views;
  spec.noise_px = 0.2;
  spec.distance_min_m = 0.25;
  spec.distance_max_m = 0.6;
  spec.centre_fraction = centre_fraction;
  return testing::make_views(truth, BoardSpec{10, 7, 0.03}, spec);
}

void print_evidence(const ModelSelection& sel) {
  for (const auto& e : sel.evidence)
    std::printf("  %-60s %3d params rms %.4f heldout %.4f solve %.3f s %s %s\n",
                e.lensmodel.c_str(), e.params, e.rms_px, e.heldout_px, e.solve_s,
                e.ok ? "" : e.error.c_str(), e.note.c_str());
}

// A fisheye whose field is 180 deg across the imager's width (stereographic, r = 2 f
// tan(theta / 2), f = 320 px on 1280 px): no OpenCV model reaches its edges. The data call
// for a fisheye model; the one chosen gives the field of view, defined, near the truth.
TEST(ModelSelection, FisheyeGetsAFisheyeModelAndADefinedFieldOfView) {
  const LensModel truth{"LENSMODEL_STEREOGRAPHIC", {320, 320, 639.5, 399.5}, 1280, 800};
  auto truth_fov = field_of_view(truth);
  ASSERT_TRUE(truth_fov.ok());
  EXPECT_NEAR(truth_fov->horizontal_deg, 180.0, 1e-6);
  const auto data = wide_lens_views(truth, 30, 0.95);
  auto sel = select_model(data, SolveOptions{}, default_candidate_models());
  ASSERT_TRUE(sel.ok()) << sel.error().message;
  print_evidence(*sel);
  const std::string& chosen = sel->chosen.model.lensmodel;
  EXPECT_NE(chosen.find("STEREOGRAPHIC"), std::string::npos) << chosen;
  auto fov = field_of_view(sel->chosen.model);
  ASSERT_TRUE(fov.ok()) << fov.error().message;
  EXPECT_NEAR(fov->horizontal_deg, 180.0, 1.0);
  EXPECT_NEAR(fov->vertical_deg, truth_fov->vertical_deg, 1.0);
  EXPECT_LT(sel->chosen.rms_px, 0.3);
}

// A wide lens that is no stereographic one (mrcal's LONLAT: x = f longitude, y = f
// latitude), 180 deg across: neither an OpenCV model nor the stereographic one fits it
// (5 px RMS), the splined stereographic model does, and gives the field of view.
TEST(ModelSelection, WideLonLatLensGetsADefinedFieldOfView) {
  const double f = 640 / (M_PI / 2);
  const LensModel truth{"LENSMODEL_LONLAT", {f, f, 639.5, 399.5}, 1280, 800};
  auto truth_fov = field_of_view(truth);
  ASSERT_TRUE(truth_fov.ok());
  // Boards reach the imager's edges: where none was, a spline extrapolates (170 deg read
  // with boards aimed across the central 95%).
  const auto data = wide_lens_views(truth, 40, 1.0);
  auto sel = select_model(data, SolveOptions{}, default_candidate_models());
  ASSERT_TRUE(sel.ok()) << sel.error().message;
  print_evidence(*sel);
  auto fov = field_of_view(sel->chosen.model);
  ASSERT_TRUE(fov.ok()) << sel->chosen.model.lensmodel << ": " << fov.error().message;
  std::printf("chosen %s: FOV %.2f x %.2f deg (truth %.2f x %.2f)\n",
              sel->chosen.model.lensmodel.c_str(), fov->horizontal_deg, fov->vertical_deg,
              truth_fov->horizontal_deg, truth_fov->vertical_deg);
  EXPECT_NE(sel->chosen.model.lensmodel.find("SPLINED_STEREOGRAPHIC"), std::string::npos);
  EXPECT_NEAR(fov->horizontal_deg, truth_fov->horizontal_deg, 2.0);
  EXPECT_NEAR(fov->vertical_deg, truth_fov->vertical_deg, 2.0);
  EXPECT_LT(sel->chosen.rms_px, 0.35);
}

// Beyond 180 deg the field of view is the sum of the edges' angles off the axis, not the
// angle between their directions (which folds back under 180).
TEST(ModelSelection, FieldOfViewBeyondHalfASphere) {
  const LensModel truth{"LENSMODEL_STEREOGRAPHIC", {250, 250, 639.5, 399.5}, 1280, 800};
  auto fov = field_of_view(truth);
  ASSERT_TRUE(fov.ok()) << fov.error().message;
  const double deg = 180 / M_PI;
  EXPECT_NEAR(fov->horizontal_deg, 4 * std::atan(640.0 / (2 * 250)) * deg, 1e-6);
  EXPECT_NEAR(fov->vertical_deg, 4 * std::atan(400.0 / (2 * 250)) * deg, 1e-6);
  EXPECT_GT(fov->horizontal_deg, 200);
  auto parts = field_of_view_parts(truth);
  ASSERT_TRUE(parts.ok() && parts->horizontal_deg);
  EXPECT_NEAR(*parts->horizontal_deg, fov->horizontal_deg, 1e-9);
}

}  // namespace model_selection_test
}  // namespace
}  // namespace camlab::calib
