// Stereo rectification of a rig's pair (calib/rig/rectification.h): rows agree on the
// truth, on a solved calibration to what its uncertainty allows, and the rectified frame is
// mrcal-stereo's.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "calib/model_io.h"
#include "calib/mrcal_api.h"
#include "calib/rig/rectification.h"
#include "calib/rig/rig_pose.h"
#include "calib/rig/rig_solver.h"
#include "synthetic_rig.h"

namespace camlab::calib {
namespace {
namespace rig_stereo_test {

namespace fs = std::filesystem;
const BoardSpec kBoard{10, 7, 0.05};

using testing::truth_solution;

struct Pair {
  std::vector<testing::RigCameraTruth> truth = testing::stereo_pair_truth();
  RigData noisy, exact;  // the same poses, with 0.3 px of noise and without
  RigSolution solved;
};

Pair solved_pair() {
  Pair p;
  testing::RigViewSpec spec;
  spec.seed = 3;
  p.noisy = testing::make_rig_views(p.truth, kBoard, spec);
  spec.noise_px = 0;
  p.exact = testing::make_rig_views(p.truth, kBoard, spec);
  RigSolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV4";
  auto s = solve_rig(p.noisy, options);
  EXPECT_TRUE(s.ok()) << s.error().message;
  if (s) p.solved = *s;
  return p;
}

TEST(RigStereo, RowsAgreeOnTheTruthAndWithinATenthOfAPixelThroughTheCalibration) {
  const Pair p = solved_pair();
  ASSERT_EQ(p.solved.cameras.size(), 2u);
  // The poses are the same with and without noise (the noise draws do not move them).
  ASSERT_EQ(p.exact.cameras[0].views.size(), p.noisy.cameras[0].views.size());
  const RigSolution truth = truth_solution(p.truth);
  auto exact_rect = rectify_pair(truth, 1);
  ASSERT_TRUE(exact_rect.ok()) << exact_rect.error().message;
  auto on_truth = epipolar_residual(*exact_rect, p.exact, truth);
  ASSERT_TRUE(on_truth.ok()) << on_truth.error().message;
  EXPECT_LT(on_truth->rms_px, 1e-6) << "rows of the truth's corners through the truth";
  auto rect = rectify_pair(p.solved, 1);
  ASSERT_TRUE(rect.ok()) << rect.error().message;
  auto through_calibration = epipolar_residual(*rect, p.exact, p.solved);
  auto noisy = epipolar_residual(*rect, p.noisy, p.solved);
  ASSERT_TRUE(through_calibration.ok() && noisy.ok());
  std::printf(
      "rectified %dx%d, az0 %.2f deg: epipolar residual of the truth's corners %.2e px "
      "(truth), %.4f px RMS, worst %.4f (solved calibration, %d corners); of the noisy "
      "corners %.3f px\n",
      rect->rectified.width_px, rect->rectified.height_px, rect->az0_deg, on_truth->rms_px,
      through_calibration->rms_px, through_calibration->worst_px, through_calibration->corners,
      noisy->rms_px);
  EXPECT_LT(through_calibration->rms_px, 0.1);
  EXPECT_GT(through_calibration->corners, 500);
  // The rectified images: a truth corner lands on one row in both (maps sampled at it).
  auto map0 = rectification_maps(*exact_rect, truth, 0);
  ASSERT_TRUE(map0.ok()) << map0.error().message;
  EXPECT_EQ((*map0)[0].cols, exact_rect->rectified.width_px);
  const cv::Point centre((*map0)[0].cols / 2, (*map0)[0].rows / 2);
  const float x = (*map0)[0].at<float>(centre), y = (*map0)[1].at<float>(centre);
  auto back = rectified_pixels(*exact_rect, truth, 0, {x, y});
  ASSERT_TRUE(back.ok());
  EXPECT_NEAR((*back)[0], centre.x, 1e-3);
  EXPECT_NEAR((*back)[1], centre.y, 1e-3);
}

// mrcal-stereo on camlab's models of the pair: its rectified0.cameramodel has the frame
// camlab's rectification has, and its rectified rows agree as well on the truth's corners.
TEST(RigStereo, TheRectifiedFrameIsMrcalStereos) {
  if (!fs::exists("/usr/bin/mrcal-stereo") || !fs::exists("/usr/bin/python3"))
    GTEST_SKIP() << "mrcal-stereo (Debian's mrcal) is absent";
  const Pair p = solved_pair();
  ASSERT_EQ(p.solved.cameras.size(), 2u);
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_rig_stereo_" + std::to_string(getpid()));
  fs::create_directories(dir);
  for (int c = 0; c < 2; ++c)
    std::ofstream(dir / ("camera-" + std::to_string(c) + ".cameramodel"))
        << cameramodel_text(p.solved.cameras[c].model, "", p.solved.cameras[c].rt_cam_ref);
  for (const auto& [model, name] : {std::pair{RectifiedModel::kPinhole, "LENSMODEL_PINHOLE"},
                                    std::pair{RectifiedModel::kLatlon, "LENSMODEL_LATLON"}}) {
    SCOPED_TRACE(name);
    auto ours = rectify_pair(p.solved, 1, 60, 40, model);
    ASSERT_TRUE(ours.ok()) << ours.error().message;
    const fs::path out = dir / name;
    const std::string command =
        "/usr/bin/python3 /usr/bin/mrcal-stereo --az-fov-deg 60 --el-fov-deg 40 "
        "--rectification " +
        std::string(name) + " --outdir " + out.string() + " " +
        (dir / "camera-0.cameramodel").string() + " " + (dir / "camera-1.cameramodel").string() +
        " > " + (dir / "log").string() + " 2>&1";
    fs::create_directories(out);
    ASSERT_EQ(std::system(command.c_str()), 0) << "see " << dir / "log";
    mrcal_cameramodel_t* theirs =
        mrcal_read_cameramodel_file((out / "rectified0.cameramodel").c_str());
    ASSERT_NE(theirs, nullptr);
    StereoRectification theirs_rect = *ours;
    for (int k = 0; k < 6; ++k) theirs_rect.rt_rect_ref[k] = theirs->rt_cam_ref[k];
    theirs_rect.rectified.intrinsics.assign(theirs->intrinsics, theirs->intrinsics + 4);
    theirs_rect.rectified.width_px = static_cast<int>(theirs->imagersize[0]);
    theirs_rect.rectified.height_px = static_cast<int>(theirs->imagersize[1]);
    mrcal_free_cameramodel(&theirs);
    const double apart_deg = rotation_between_deg(ours->rt_rect_ref, theirs_rect.rt_rect_ref);
    auto ours_residual = epipolar_residual(*ours, p.exact, p.solved);
    auto theirs_residual = epipolar_residual(theirs_rect, p.exact, p.solved);
    ASSERT_TRUE(ours_residual.ok() && theirs_residual.ok());
    std::printf(
        "%s: rectified frames %.2e deg apart; epipolar residual of the truth's corners: camlab "
        "%.4f px, mrcal-stereo's rectification %.4f px; imagers %dx%d and %dx%d\n",
        name, apart_deg, ours_residual->rms_px, theirs_residual->rms_px, ours->rectified.width_px,
        ours->rectified.height_px, theirs_rect.rectified.width_px, theirs_rect.rectified.height_px);
    EXPECT_LT(apart_deg, 1e-6);
    EXPECT_LT(ours_residual->rms_px, 0.1);
    // Rows scale with the focal length each rectification chose; the residuals agree to that.
    EXPECT_NEAR(ours_residual->rms_px / ours->rectified.intrinsics[1],
                theirs_residual->rms_px / theirs_rect.rectified.intrinsics[1],
                0.05 * ours_residual->rms_px / ours->rectified.intrinsics[1]);
  }
  fs::remove_all(dir);
}

// A fisheye pair (180 deg stereographic lenses, 0.12 m apart): a pinhole rectification
// cannot span their field, the lat-lon one does, evenly in angle, and its rows agree on
// the truth's corners wherever they are, 80 deg off the axis included.
TEST(RigStereo, AFisheyePairIsRectifiedLatLonAcrossItsWholeField) {
  const double deg = M_PI / 180;
  const LensModel fisheye{"LENSMODEL_STEREOGRAPHIC", {320, 320, 639.5, 399.5}, 1280, 800};
  const std::vector<testing::RigCameraTruth> truth_rig = {
      {fisheye, {0, 0, 0, 0, 0, 0}}, {fisheye, {0.004, -3 * deg, 0.5 * deg, -0.12, 0.002, 0.0}}};
  testing::RigViewSpec spec;
  spec.views = 40;
  spec.noise_px = 0;
  spec.distance_min_m = 0.4;
  const RigData exact = testing::make_rig_views(truth_rig, kBoard, spec);
  const RigSolution truth = truth_solution(truth_rig);

  EXPECT_EQ(rectify_pair(truth, 1, 180, 140).error().code, "out_of_range")
      << "no pinhole spans 180 deg";
  auto wide_pinhole = rectify_pair(truth, 1, 150, 140);
  auto latlon = rectify_pair(truth, 1, 180, 140, RectifiedModel::kLatlon);
  ASSERT_TRUE(wide_pinhole.ok() && latlon.ok()) << latlon.error().message;
  EXPECT_EQ(latlon->rectified.lensmodel, "LENSMODEL_LATLON");
  EXPECT_NEAR(latlon->rectified.width_px, 320 * M_PI, 1) << "f pixels a radian";
  auto residual = epipolar_residual(*latlon, exact, truth);
  ASSERT_TRUE(residual.ok()) << residual.error().message;
  // How far off the axis the corners reach (their rectified columns), and whether any
  // lies beyond what the widest pinhole keeps.
  double widest_az_deg = 0;
  int beyond_pinhole = 0;
  for (const auto& view : exact.cameras[0].views) {
    std::vector<double> q;
    for (const auto& c : view.corners)
      if (c.present) q.insert(q.end(), {c.x_px, c.y_px});
    if (q.empty()) continue;
    auto r = rectified_pixels(*latlon, truth, 0, q);
    ASSERT_TRUE(r.ok());
    for (size_t i = 0; i < r->size(); i += 2) {
      const double az_deg =
          ((*r)[i] - latlon->rectified.intrinsics[2]) / latlon->rectified.intrinsics[0] / deg;
      widest_az_deg = std::max(widest_az_deg, std::abs(az_deg));
      beyond_pinhole += std::abs(az_deg - latlon->az0_deg) > 75;
    }
  }
  std::printf(
      "fisheye pair: lat-lon %dx%d for 180 x 140 deg (a 150-deg pinhole: %dx%d); rows of %d "
      "truth corners in %d views %.2e px apart (worst %.2e); corners up to %.1f deg off the "
      "axis, %d beyond a 150-deg pinhole\n",
      latlon->rectified.width_px, latlon->rectified.height_px, wide_pinhole->rectified.width_px,
      wide_pinhole->rectified.height_px, residual->corners, residual->views, residual->rms_px,
      residual->worst_px, widest_az_deg, beyond_pinhole);
  EXPECT_LT(residual->worst_px, 1e-6);
  EXPECT_GT(residual->corners, 1000);
  EXPECT_GT(widest_az_deg, 75);
  EXPECT_GT(wide_pinhole->rectified.width_px, 2 * latlon->rectified.width_px)
      << "the pinhole's tangents blow the width up";
  // Ranges from the rectified columns: points 1.5 m from camera 0, up to 80 deg off its
  // axis, through both rectifications (the pinhole's within its 150 deg).
  for (const double az_deg : {0.0, 30.0, -50.0, 70.0, 80.0}) {
    const double range_m = 1.5;
    const cv::Vec3d point(range_m * std::sin(az_deg * deg) * std::cos(10 * deg),
                          range_m * std::sin(10 * deg),
                          range_m * std::cos(az_deg * deg) * std::cos(10 * deg));
    for (const auto* rect : {&*latlon, &*wide_pinhole}) {
      if (rect == &*wide_pinhole && std::abs(az_deg) > 70) continue;
      double x[2], y0 = 0;
      for (int c = 0; c < 2; ++c) {
        const cv::Matx33d R = rotation_matrix(truth.cameras[c].rt_cam_ref);
        const auto& rt = truth.cameras[c].rt_cam_ref;
        const cv::Vec3d p = R * point + cv::Vec3d(rt[3], rt[4], rt[5]);
        auto q = project(fisheye, {p[0], p[1], p[2]});
        ASSERT_TRUE(q.ok());
        auto r = rectified_pixels(*rect, truth, c, *q);
        ASSERT_TRUE(r.ok());
        x[c] = (*r)[0];
        if (c == 0) y0 = (*r)[1];
      }
      EXPECT_NEAR(rectified_range_m(*rect, x[0], y0, x[1]), range_m, 1e-6)
          << rect->rectified.lensmodel << ", " << az_deg << " deg";
    }
  }
  EXPECT_TRUE(std::isnan(rectified_range_m(*latlon, 100, 300, 120))) << "no crossing in front";

  // The maps: a rectified pixel 80 deg off the axis comes from the fisheye's image and
  // goes back to itself.
  auto maps = rectification_maps(*latlon, truth, 1);
  ASSERT_TRUE(maps.ok()) << maps.error().message;
  const cv::Point far(static_cast<int>(latlon->rectified.intrinsics[2] + 80 * deg * 320),
                      latlon->rectified.height_px / 2);
  const float x = (*maps)[0].at<float>(far), y = (*maps)[1].at<float>(far);
  ASSERT_GE(x, 0);
  ASSERT_LT(x, 1280);
  auto back = rectified_pixels(*latlon, truth, 1, {x, y});
  ASSERT_TRUE(back.ok());
  EXPECT_NEAR((*back)[0], far.x, 1e-3);
  EXPECT_NEAR((*back)[1], far.y, 1e-3);
}

TEST(RigStereo, CamerasOnOneCentreOrLookingAlongTheBaselineAreRefused) {
  auto truth = truth_solution(testing::stereo_pair_truth());
  truth.cameras[1].rt_cam_ref = {0, 0.1, 0, 0, 0, 0};
  auto same_centre = rectify_pair(truth, 1);
  ASSERT_FALSE(same_centre.ok());
  EXPECT_NE(same_centre.error().text().find("singular"), std::string::npos);
  truth.cameras[1].rt_cam_ref = {0, 0, 0, 0, 0, -0.2};  // camera 1 straight ahead of camera 0
  auto along = rectify_pair(truth, 1);
  ASSERT_FALSE(along.ok());
  EXPECT_NE(along.error().message.find("along their baseline"), std::string::npos);
  EXPECT_FALSE(rectify_pair(truth, 2).ok());
  EXPECT_FALSE(rectify_pair(truth_solution(testing::stereo_pair_truth()), 1, 175, 40).ok());
}

}  // namespace rig_stereo_test
}  // namespace
}  // namespace camlab::calib
