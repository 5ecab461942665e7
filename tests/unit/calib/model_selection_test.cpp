// `--model auto`: the simplest model the held-out views support, chosen by projection.
#include <gtest/gtest.h>

#include "calib/model_selection.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

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

}  // namespace
}  // namespace camlab::calib
