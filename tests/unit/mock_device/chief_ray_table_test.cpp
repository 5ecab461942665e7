// The chief-ray table against mrcal's exact projection.
#include <gtest/gtest.h>

#include <cmath>

#include "mock_device/render/chief_ray_table.h"
#include "mock_device/spec/mrcal_api.h"

namespace camlab::mock {
namespace {

const std::vector<double> kWideOpencv8 = {733.3,  733.3,   642.3,  398.1, -0.22, 0.05,
                                          0.0004, -0.0003, -0.003, 0.05,  0.01,  0.0};

// Projects a normalised ray (xn, yn, 1) with mrcal.
mrcal_point2_t project(const std::vector<double>& intrinsics, double xn, double yn) {
  mrcal_lensmodel_t lensmodel;
  mrcal_lensmodel_from_name(&lensmodel, "LENSMODEL_OPENCV8");
  mrcal_point3_t p{.x = xn, .y = yn, .z = 1.0};
  mrcal_point2_t q;
  mrcal_project(&q, nullptr, nullptr, &p, 1, &lensmodel, intrinsics.data());
  return q;
}

TEST(ChiefRayTable, CornersReprojectToThemselves) {
  auto table = ChiefRayTable::create("LENSMODEL_OPENCV8", kWideOpencv8, 1280, 800);
  ASSERT_TRUE(table.ok()) << table.error().message;
  EXPECT_EQ(table->invalid_fraction(), 0.0) << "the example wide lens covers its whole imager";
  double worst_px = 0;
  for (int j = 0; j <= 800; j += 37)
    for (int i = 0; i <= 1280; i += 41) {
      const auto q = project(kWideOpencv8, table->xn(i, j), table->yn(i, j));
      worst_px = std::max(worst_px, std::hypot(q.x - (i - 0.5), q.y - (j - 0.5)));
    }
  EXPECT_LT(worst_px, 2e-4);  // float storage of xn, yn
}

TEST(ChiefRayTable, RescaledTableEqualsAFreshUnprojectionAtTheNewFocalLength) {
  auto table = ChiefRayTable::create("LENSMODEL_OPENCV8", kWideOpencv8, 1280, 800);
  ASSERT_TRUE(table.ok());
  const double ratio = 1.05;  // focused close: the lens 5% further from the sensor
  ChiefRayTable rescaled = table->rescaled(ratio);
  std::vector<double> intrinsics = kWideOpencv8;
  intrinsics[0] *= ratio;
  intrinsics[1] *= ratio;
  double worst_px = 0;
  for (int j = 0; j <= 800; j += 29)
    for (int i = 0; i <= 1280; i += 31) {
      ASSERT_TRUE(rescaled.valid(i, j));
      const auto q = project(intrinsics, rescaled.xn(i, j), rescaled.yn(i, j));
      worst_px = std::max(worst_px, std::hypot(q.x - (i - 0.5), q.y - (j - 0.5)));
    }
  EXPECT_LT(worst_px, 2e-3) << "bilinear resampling of the reference table";
}

TEST(ChiefRayTable, AModelThatFoldsOverMarksTheFoldedPixelsInvalid) {
  // Strong barrel distortion whose radial map peaks inside the imager: the corners have
  // no preimage, and must be flagged rather than rendered from a wrong ray.
  std::vector<double> folded = {733.3, 733.3, 642.3, 398.1, -0.28, 0.08,
                                0.0,   0.0,   -0.01, 0.05,  0.01,  0.0};
  auto table = ChiefRayTable::create("LENSMODEL_OPENCV8", folded, 1280, 800);
  ASSERT_TRUE(table.ok());
  EXPECT_GT(table->invalid_fraction(), 0.01);
  EXPECT_FALSE(table->valid(0, 0));
  EXPECT_TRUE(table->valid(640, 400));
}

}  // namespace
}  // namespace camlab::mock
