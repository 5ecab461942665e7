// Lens geometry by projection: FOV from unprojected edges, projection differences, and
// the output files (mrcal reads the .cameramodel back; OpenCV reads the YAML back).
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "calib/lens_model.h"
#include "calib/model_io.h"
#include "calib/mrcal_api.h"

namespace camlab::calib {
namespace {

TEST(LensModel, PinholeFovMatchesTheClosedForm) {
  // Principal point at the imager centre: the half-extent to a pixel edge is W / 2.
  const LensModel m{"LENSMODEL_PINHOLE", {800, 800, 639.5, 399.5}, 1280, 800};
  auto fov = field_of_view(m);
  ASSERT_TRUE(fov.ok());
  constexpr double kDeg = 180 / M_PI;
  EXPECT_NEAR(fov->horizontal_deg, 2 * std::atan(640.0 / 800) * kDeg, 1e-9);
  EXPECT_NEAR(fov->vertical_deg, 2 * std::atan(400.0 / 800) * kDeg, 1e-9);
  EXPECT_NEAR(fov->diagonal_deg, 2 * std::atan(std::hypot(640.0, 400.0) / 800) * kDeg, 1e-9);
}

TEST(LensModel, StereographicFovMatchesTheClosedForm) {
  // q = 2 f tan(theta / 2): the edge at 640 px is at theta = 2 atan(640 / 2f).
  const LensModel m{"LENSMODEL_STEREOGRAPHIC", {500, 500, 639.5, 399.5}, 1280, 800};
  auto fov = field_of_view(m);
  ASSERT_TRUE(fov.ok());
  EXPECT_NEAR(fov->horizontal_deg, 4 * std::atan(640.0 / 1000) * 180 / M_PI, 1e-7);
}

// OPENCV4 with k2 only: r_d = r (1 + k2 r^4) in normalised coordinates. With k2 = -0.143
// the projection folds at r* = (1 / (5 |k2|))^(1/4) = 1.087, where r_d peaks at 0.8 r* =
// 0.87: the edge midpoints (r_d 0.8 and 0.5) invert, the image corners (r_d 0.943) do
// not. The expected FOV solve r + k2 r^5 = r_d by bisection below the fold, here, not
// through camlab's unprojection.
TEST(LensModel, FovPartsWhereTheModelFoldsOnlyInTheImageCorners) {
  const double f = 800, k2 = -0.143;
  const LensModel m{"LENSMODEL_OPENCV4", {f, f, 639.5, 399.5, 0, k2, 0, 0}, 1280, 800};
  auto full = field_of_view(m);
  EXPECT_FALSE(full.ok()) << "the model should not invert at the image corners";
  auto parts = field_of_view_parts(m);
  ASSERT_TRUE(parts.ok()) << parts.error().message;
  auto undistort = [&](double rd) {
    double lo = 0, hi = std::pow(1 / (5 * std::fabs(k2)), 0.25);
    for (int i = 0; i < 200; ++i) {
      const double mid = 0.5 * (lo + hi);
      (mid + k2 * std::pow(mid, 5) < rd ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  constexpr double kDeg = 180 / M_PI;
  ASSERT_TRUE(parts->horizontal_deg && parts->vertical_deg);
  EXPECT_FALSE(parts->diagonal_deg);
  EXPECT_FALSE(parts->all());
  EXPECT_TRUE(parts->any());
  EXPECT_NEAR(*parts->horizontal_deg, 2 * std::atan(undistort(640.0 / f)) * kDeg, 1e-6);
  EXPECT_NEAR(*parts->vertical_deg, 2 * std::atan(undistort(400.0 / f)) * kDeg, 1e-6);

  // A model that inverts everywhere has all three, equal to field_of_view()'s.
  const LensModel pinhole{"LENSMODEL_PINHOLE", {f, f, 639.5, 399.5}, 1280, 800};
  auto p = field_of_view_parts(pinhole);
  auto q = field_of_view(pinhole);
  ASSERT_TRUE(p.ok() && q.ok() && p->all());
  EXPECT_DOUBLE_EQ(*p->horizontal_deg, q->horizontal_deg);
  EXPECT_DOUBLE_EQ(*p->vertical_deg, q->vertical_deg);
  EXPECT_DOUBLE_EQ(*p->diagonal_deg, q->diagonal_deg);
}

TEST(LensModel, ProjectionDifferenceSeesAFocalChange) {
  const LensModel a{"LENSMODEL_PINHOLE", {800, 800, 639.5, 399.5}, 1280, 800};
  LensModel b = a;
  auto same = projection_difference(a, b, 0.8);
  ASSERT_TRUE(same.ok());
  EXPECT_LT(same->rms_px, 1e-9);
  b.intrinsics[0] = b.intrinsics[1] = 800.8;  // +0.1%: 0.1% of the radius
  auto d = projection_difference(a, b, 0.8);
  ASSERT_TRUE(d.ok());
  // The farthest sample sits near 0.8 * (640, 400) from the centre: 0.001 * 603 px.
  EXPECT_NEAR(d->max_px, 0.001 * std::hypot(0.8 * 640, 0.8 * 400), 0.02);
  EXPECT_GT(d->rms_px, 0.2);
}

TEST(LensModel, RejectsUnknownModels) {
  EXPECT_FALSE(lensmodel_param_count("LENSMODEL_NOPE").ok());
  auto n = lensmodel_param_count("LENSMODEL_OPENCV8");
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 12);
  auto splined = configured_lensmodel("SPLINED_STEREOGRAPHIC", 1280, 800, 100);
  ASSERT_TRUE(splined.ok()) << splined.error().message;
  EXPECT_EQ(*splined, "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=116");
}

TEST(ModelIo, MrcalReadsTheCameramodelBackExactly) {
  const LensModel m{"LENSMODEL_OPENCV8",
                    {733.1234567890123, 733.5, 642.3, 398.1, -0.22, 0.05, 0.0004, -0.0003, -0.003,
                     0.05, 0.01, 1.0 / 3},
                    1280,
                    800};
  const std::string text = cameramodel_text(m, "test");
  mrcal_cameramodel_t* read = mrcal_read_cameramodel_string(text.c_str(), 0);
  ASSERT_NE(read, nullptr) << text;
  EXPECT_EQ(read->lensmodel.type, MRCAL_LENSMODEL_OPENCV8);
  EXPECT_EQ(read->imagersize[0], 1280u);
  EXPECT_EQ(read->imagersize[1], 800u);
  for (size_t i = 0; i < m.intrinsics.size(); ++i) EXPECT_EQ(read->intrinsics[i], m.intrinsics[i]);
  mrcal_free_cameramodel(&read);
}

TEST(ModelIo, OpencvYamlHoldsCameraMatrixAndDistortion) {
  const LensModel m{
      "LENSMODEL_OPENCV5", {700, 701, 640, 400, -0.1, 0.02, 0.001, -0.002, 0.003}, 1280, 800};
  auto yaml = opencv_yaml_text(m);
  ASSERT_TRUE(yaml.ok());
  cv::FileStorage fs(*yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  cv::Mat K, D;
  fs["camera_matrix"] >> K;
  fs["distortion_coefficients"] >> D;
  ASSERT_EQ(K.rows, 3);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 0), 700);
  EXPECT_DOUBLE_EQ(K.at<double>(1, 1), 701);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 2), 640);
  EXPECT_DOUBLE_EQ(K.at<double>(1, 2), 400);
  ASSERT_EQ(D.total(), 5u);
  EXPECT_DOUBLE_EQ(D.at<double>(0, 4), 0.003);
  EXPECT_EQ(static_cast<int>(fs["image_width"]), 1280);
  const LensModel s{"LENSMODEL_STEREOGRAPHIC", {500, 500, 640, 400}, 1280, 800};
  EXPECT_FALSE(opencv_yaml_text(s).ok());
}

}  // namespace
}  // namespace camlab::calib
