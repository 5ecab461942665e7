// The joint rig solve (calib/rig/rig_solver.h) on synthetic rigs with known lenses and
// poses (synthetic_rig.h): extrinsics against the truth, and their stated sigma against the
// errors over many noise draws.
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "calib/lens_model.h"
#include "calib/rig/board_labels.h"
#include "calib/rig/rig_calibrate.h"
#include "calib/rig/rig_pose.h"
#include "calib/rig/rig_range.h"
#include "calib/rig/rig_solver.h"
#include "synthetic_rig.h"

namespace camlab::calib {
namespace {
namespace rig_solver_test {

const BoardSpec kBoard{10, 7, 0.05};

using testing::stereo_pair_truth;
using testing::truth_solution;

// Errors of every non-reference camera's rt_cam_ref, each component over its stated sigma.
std::vector<double> normalised_errors(const RigSolution& s,
                                      const std::vector<testing::RigCameraTruth>& truth) {
  std::vector<double> z;
  for (size_t c = 1; c < truth.size(); ++c)
    for (int k = 0; k < 6; ++k) {
      const double sigma = std::sqrt(s.cameras[c].rt_covariance[7 * k]);
      z.push_back((s.cameras[c].rt_cam_ref[k] - truth[c].rt_cam_ref[k]) / sigma);
    }
  return z;
}

TEST(RigSolve, PairsExtrinsicsAreTheTruthsWithinTheirStatedSigma) {
  const auto truth = stereo_pair_truth();
  std::vector<double> z, range_z;
  double worst_rotation_deg = 0, worst_translation_mm = 0, solve_s = 0;
  double range_sigma_mm = 0, range_sigma_intrinsics_mm = 0, range_sigma_extrinsics_mm = 0;
  const int seeds = 20;
  for (int seed = 1; seed <= seeds; ++seed) {
    testing::RigViewSpec spec;
    spec.seed = seed;
    const RigData data = testing::make_rig_views(truth, kBoard, spec);
    RigSolveOptions options;
    options.lensmodel = "LENSMODEL_OPENCV4";
    auto s = solve_rig(data, options);
    ASSERT_TRUE(s.ok()) << "seed " << seed << ": " << s.error().message;
    solve_s += s->solve_s;
    // 30 varied views a camera: nothing to warn about.
    for (const std::string& w : s->warnings)
      EXPECT_EQ(w.find("too_few_views"), std::string::npos) << "seed " << seed << ": " << w;
    const RigCamera& b = s->cameras[1];
    const double rotation_deg = rotation_between_deg(b.rt_cam_ref, truth[1].rt_cam_ref);
    double translation_m = 0;
    for (int k = 3; k < 6; ++k)
      translation_m += std::pow(b.rt_cam_ref[k] - truth[1].rt_cam_ref[k], 2);
    translation_m = std::sqrt(translation_m);
    worst_rotation_deg = std::max(worst_rotation_deg, rotation_deg);
    worst_translation_mm = std::max(worst_translation_mm, translation_m * 1000);
    // Each seed: the error is within 3 of its stated sigma (or the absolute bound).
    const double rotation_sigma_deg =
        std::hypot(b.rotation_sigma_deg[0], b.rotation_sigma_deg[1], b.rotation_sigma_deg[2]);
    const double translation_sigma_mm =
        std::hypot(b.translation_sigma_mm[0], b.translation_sigma_mm[1], b.translation_sigma_mm[2]);
    EXPECT_TRUE(rotation_deg <= 0.005 || rotation_deg <= 3 * rotation_sigma_deg)
        << "seed " << seed << ": " << rotation_deg << " deg, sigma " << rotation_sigma_deg;
    EXPECT_TRUE(translation_m * 1000 <= 0.05 * 0.2 ||
                translation_m * 1000 <= 3 * translation_sigma_mm)
        << "seed " << seed << ": " << translation_m * 1000 << " mm, sigma " << translation_sigma_mm;
    EXPECT_NEAR(b.baseline_m, 0.2003, 3 * b.baseline_sigma_mm / 1000 + 1e-4);
    EXPECT_LT(s->rms_px, 0.5);
    EXPECT_NEAR(s->corner_sigma_px, 0.3, 0.05);
    for (double v : normalised_errors(*s, truth)) z.push_back(v);
    // A point 3 m along camera 0's axis, triangulated from its true pixels through this
    // seed's calibration: its range error against the stated calibration sigma.
    auto range = triangulated_range_uncertainty(*s, 1, 3.0);
    ASSERT_TRUE(range.ok()) << range.error().message;
    const auto range_error_mm = testing::range_error_mm(*s, truth, 1, 3.0);
    ASSERT_TRUE(range_error_mm.has_value());
    range_z.push_back(*range_error_mm / range->sigma_mm);
    range_sigma_mm += range->sigma_mm / seeds;
    range_sigma_intrinsics_mm += range->sigma_intrinsics_alone_mm / seeds;
    range_sigma_extrinsics_mm += range->sigma_extrinsics_alone_mm / seeds;
    if (seed == 1)
      std::printf(
          "seed 1: rotation sigma %.5f %.5f %.5f deg, translation sigma %.4f %.4f "
          "%.4f mm, baseline %.5f +- %.4f mm, %zu views, rms %.3f px\n",
          b.rotation_sigma_deg[0], b.rotation_sigma_deg[1], b.rotation_sigma_deg[2],
          b.translation_sigma_mm[0], b.translation_sigma_mm[1], b.translation_sigma_mm[2],
          b.baseline_m, b.baseline_sigma_mm, s->views_used.size(), s->rms_px);
  }
  double sum_sq = 0;
  int beyond_2 = 0;
  for (double v : z) {
    sum_sq += v * v;
    beyond_2 += std::abs(v) > 2;
  }
  const double rms = std::sqrt(sum_sq / z.size());
  std::printf(
      "pair, %d seeds: |error|/sigma RMS %.3f, %d of %zu beyond 2 sigma; worst "
      "rotation %.5f deg, translation %.4f mm; %.3f s a solve\n",
      seeds, rms, beyond_2, z.size(), worst_rotation_deg, worst_translation_mm, solve_s / seeds);
  EXPECT_GT(rms, 0.8);
  EXPECT_LT(rms, 1.25);
  EXPECT_LT(beyond_2, 0.12 * z.size());
  double range_sq = 0;
  for (double v : range_z) range_sq += v * v;
  const double range_rms = std::sqrt(range_sq / range_z.size());
  std::printf(
      "range at 3 m: sigma %.2f mm (intrinsics alone %.2f, extrinsics alone %.2f); "
      "|error|/sigma RMS %.3f over %d seeds\n",
      range_sigma_mm, range_sigma_intrinsics_mm, range_sigma_extrinsics_mm, range_rms, seeds);
  // 20 draws: the RMS of 20 unit normals is within 0.6-1.45 in 99% of draws.
  EXPECT_GT(range_rms, 0.6);
  EXPECT_LT(range_rms, 1.45);
}

// Four wide cameras on a ring, 60 deg apart: each sees its neighbours' boards only, so
// cameras 2 and 3 are placed through the chain of neighbours.
TEST(RigSolve, RingOfFourIsPlacedThroughItsNeighbours) {
  const auto truth = testing::ring_truth(60);
  testing::RigViewSpec spec;
  spec.views = 60;
  spec.distance_min_m = 0.6;
  spec.distance_max_m = 1.4;
  const RigData data = testing::make_rig_views(truth, kBoard, spec);
  int shared_0_2 = 0;
  for (size_t v = 0; v < data.cameras[0].views.size(); ++v)
    shared_0_2 += data.cameras[0].views[v].present_count() > 0 &&
                  data.cameras[2].views[v].present_count() > 0;
  EXPECT_EQ(shared_0_2, 0) << "cameras 0 and 2 must not overlap for this test";
  RigSolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV8";
  auto s = solve_rig(data, options);
  ASSERT_TRUE(s.ok()) << s.error().message;
  std::printf("ring of 4, %zu views: solved in %.2f s\n", s->views_used.size(), s->solve_s);
  for (int c = 1; c < 4; ++c) {
    const RigCamera& cam = s->cameras[c];
    const double rotation_deg = rotation_between_deg(cam.rt_cam_ref, truth[c].rt_cam_ref);
    double translation_mm = 0;
    for (int k = 3; k < 6; ++k)
      translation_mm += std::pow(1000 * (cam.rt_cam_ref[k] - truth[c].rt_cam_ref[k]), 2);
    translation_mm = std::sqrt(translation_mm);
    const double rotation_sigma_deg =
        std::hypot(cam.rotation_sigma_deg[0], cam.rotation_sigma_deg[1], cam.rotation_sigma_deg[2]);
    const double translation_sigma_mm = std::hypot(
        cam.translation_sigma_mm[0], cam.translation_sigma_mm[1], cam.translation_sigma_mm[2]);
    std::printf(
        "camera %d: %d views, rotation error %.5f deg (sigma %.5f), translation %.4f "
        "mm (sigma %.4f), rms %.3f px\n",
        c, cam.views, rotation_deg, rotation_sigma_deg, translation_mm, translation_sigma_mm,
        cam.rms_px);
    EXPECT_LT(rotation_deg, 3 * rotation_sigma_deg + 0.005) << "camera " << c;
    EXPECT_LT(translation_mm, 3 * translation_sigma_mm + 0.01) << "camera " << c;
  }
}

// The ring with one 180 deg fisheye beside three wide pinhole lenses. mrcal 2.2
// solves one lens model for every camera of a problem, so all four take the splined
// stereographic model spanning the fisheye's field (what `--model auto` gives such a rig,
// rig_calibrate.cpp). A splined model's frame is not its optical axis: a turn of the
// camera trades with its knots, held only by mrcal's regularisation (here 10-13 deg
// against a stated 1 deg), so rt_cam_ref's rotation, and a camera's centre expressed in
// camera 0's turned frame, are not compared with the truth. What a user measures with the
// rig is: the distances between the cameras' centres, and points triangulated through the
// solved lenses and poses. Those are biased by the regularisation, within what the solve
// states at 60 views (baselines 0.4-0.6% long, 1.6-1.8 sigma; ranges 0.4-0.5 sigma) but not
// at 40 (2.6 and 4.7 sigma): docs/calibration.md, "Camera rigs".
TEST(RigSolve, RingWithAFisheyeIsSolvedInOneSplinedModel) {
  const auto truth = testing::ring_with_fisheye_truth(60, 1);
  testing::RigViewSpec spec;
  spec.views = 60;
  spec.distance_min_m = 0.6;
  spec.distance_max_m = 1.4;
  const RigData data = testing::make_rig_views(truth, kBoard, spec);
  RigSolveOptions options;
  // configured_lensmodel()'s grid (16 x 10 knots over 204 deg); 24 x 15 knots take 8x the
  // time and give the same distances within 0.4 mm.
  auto model = configured_lensmodel("LENSMODEL_SPLINED_STEREOGRAPHIC", 1280, 800, 180);
  ASSERT_TRUE(model.ok()) << model.error().message;
  options.lensmodel = *model;
  auto s = solve_rig(data, options);
  ASSERT_TRUE(s.ok()) << s.error().message;
  std::printf("ring of 4 with a fisheye, %s, %zu views: solved in %.2f s, rms %.3f px\n",
              options.lensmodel.c_str(), s->views_used.size(), s->solve_s, s->rms_px);
  auto centre = [](const Rt& rt) {
    const cv::Matx44d m = testing::rt_matrix(rt).inv();
    return cv::Vec3d(m(0, 3), m(1, 3), m(2, 3));
  };
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) {
      const double solved_mm =
          1000 * cv::norm(centre(s->cameras[a].rt_cam_ref) - centre(s->cameras[b].rt_cam_ref));
      const double truth_mm =
          1000 * cv::norm(centre(truth[a].rt_cam_ref) - centre(truth[b].rt_cam_ref));
      std::printf("cameras %d-%d: %.3f mm apart (truth %.3f; sigma %.3f mm)\n", a, b, solved_mm,
                  truth_mm, a == 0 ? s->cameras[b].baseline_sigma_mm : 0.0);
      if (a == 0) {
        EXPECT_LT(std::abs(solved_mm - truth_mm), 2.5 * s->cameras[b].baseline_sigma_mm)
            << "camera " << b << ": baseline sigma " << s->cameras[b].baseline_sigma_mm << " mm";
      }
      EXPECT_LT(std::abs(solved_mm - truth_mm), 0.01 * truth_mm) << "cameras " << a << "-" << b;
    }
  for (int c = 0; c < 4; ++c) EXPECT_LT(s->cameras[c].rms_px, 0.45) << "camera " << c;
  // Points 1 m and 2 m from camera 0 (on its true axis), their true pixels in camera 0 and
  // the fisheye triangulated through the solved rig: the range against the truth's.
  for (double range_m : {1.0, 2.0}) {
    const cv::Vec3d p0(0, 0, range_m);
    const cv::Matx44d to1 = testing::rt_matrix(truth[1].rt_cam_ref);
    const cv::Vec4d p1 = to1 * cv::Vec4d(p0[0], p0[1], p0[2], 1);
    auto q0 = project(truth[0].lens, {p0[0], p0[1], p0[2]});
    auto q1 = project(truth[1].lens, {p1[0], p1[1], p1[2]});
    ASSERT_TRUE(q0.ok() && q1.ok());
    auto point =
        triangulate_midpoint(s->cameras[0].model, s->cameras[1].model, s->cameras[1].rt_cam_ref,
                             {(*q0)[0], (*q0)[1]}, {(*q1)[0], (*q1)[1]});
    ASSERT_TRUE(point.ok()) << point.error().message;
    const double error_mm = 1000 * (std::hypot((*point)[0], (*point)[1], (*point)[2]) - range_m);
    const auto stated = triangulated_range_uncertainty(*s, 1, range_m);
    ASSERT_TRUE(stated.ok()) << stated.error().message;
    std::printf(
        "range %.0f m through camera 0 and the fisheye: error %.3f mm (stated sigma "
        "%.3f mm)\n",
        range_m, error_mm, stated->sigma_mm);
    EXPECT_LT(std::abs(error_mm), 3 * stated->sigma_mm);
  }
  bool warned = false;
  for (const std::string& w : s->warnings) warned |= w.rfind("splined_model:", 0) == 0;
  EXPECT_TRUE(warned) << "the splined model's limits are stated";
  // The fisheye's field comes back defined and near the truth's 180 deg.
  auto fov = field_of_view(s->cameras[1].model);
  ASSERT_TRUE(fov.ok()) << fov.error().message;
  std::printf("fisheye: horizontal FOV %.2f deg (truth 180)\n", fov->horizontal_deg);
  EXPECT_NEAR(fov->horizontal_deg, 180.0, 2.0);
}

// The stacked solve (one mrcal problem a camera, rig_joint_solve.h) on a rig of one model
// reaches mrcal_optimize's state: the same extrinsics, intrinsics and stated sigma. What
// ties the cameras' problems (shared board poses and warp, their packing scales, each
// state's place in the stacked vector) is checked against mrcal's own joint problem.
TEST(RigSolve, StackedSolveOfOneModelIsMrcalsJointSolve) {
  const auto truth = stereo_pair_truth();
  testing::RigViewSpec spec;
  spec.views = 30;
  const RigData data = testing::make_rig_views(truth, kBoard, spec);
  RigSolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV4";
  auto mrcal_joint = solve_rig(data, options);
  ASSERT_TRUE(mrcal_joint.ok()) << mrcal_joint.error().message;
  options.stacked_solve = true;
  auto stacked = solve_rig(data, options);
  ASSERT_TRUE(stacked.ok()) << stacked.error().message;
  std::printf("pair, one model: mrcal_optimize %.3f s, stacked %.3f s; rms %.5f vs %.5f px\n",
              mrcal_joint->solve_s, stacked->solve_s, mrcal_joint->rms_px, stacked->rms_px);
  EXPECT_NEAR(stacked->rms_px, mrcal_joint->rms_px, 1e-5);
  EXPECT_NEAR(stacked->corner_sigma_px, mrcal_joint->corner_sigma_px, 1e-5);
  const RigCamera &a = mrcal_joint->cameras[1], &b = stacked->cameras[1];
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(b.rt_cam_ref[k], a.rt_cam_ref[k], 1e-7) << "rotation " << k;             // rad
    EXPECT_NEAR(b.rt_cam_ref[3 + k], a.rt_cam_ref[3 + k], 1e-7) << "translation " << k;  // m
    EXPECT_NEAR(b.rotation_sigma_deg[k], a.rotation_sigma_deg[k], 0.01 * a.rotation_sigma_deg[k]);
    EXPECT_NEAR(b.translation_sigma_mm[k], a.translation_sigma_mm[k],
                0.01 * a.translation_sigma_mm[k]);
  }
  for (int c = 0; c < 2; ++c)
    for (size_t k = 0; k < 4; ++k)
      EXPECT_NEAR(stacked->cameras[c].model.intrinsics[k],
                  mrcal_joint->cameras[c].model.intrinsics[k], 1e-4)
          << "camera " << c << " intrinsic " << k;  // px
  ASSERT_EQ(stacked->parameter_count, mrcal_joint->parameter_count);
  EXPECT_EQ(stacked->cameras[1].outliers, mrcal_joint->cameras[1].outliers);
}

// The ring with a 180 deg fisheye, each camera in its own model (the wide lenses
// OPENCV8, the fisheye STEREOGRAPHIC, as their own model selections choose): every camera's
// rotation within 0.005 deg of the truth or 2 stated sigma, its translation within 0.05 mm
// per metre of baseline or 2 stated sigma, and the sigma honest over the seeds.
TEST(RigSolve, RingWithAFisheyeKeepsEachCamerasModel) {
  const auto truth = testing::ring_with_fisheye_truth(60, 1);
  std::vector<double> z;
  int beyond = 0;
  double worst_rotation_deg = 0, worst_rotation_sigmas = 0, solve_s = 0;
  const int seeds = 6;
  for (int seed = 1; seed <= seeds; ++seed) {
    testing::RigViewSpec spec;
    spec.views = 50;
    spec.distance_min_m = 0.6;
    spec.distance_max_m = 1.4;
    spec.seed = seed;
    const RigData data = testing::make_rig_views(truth, kBoard, spec);
    RigSolveOptions options;
    for (const auto& cam : truth) options.lensmodels.push_back(cam.lens.lensmodel);
    auto s = solve_rig(data, options);
    ASSERT_TRUE(s.ok()) << "seed " << seed << ": " << s.error().message;
    solve_s += s->solve_s / seeds;
    for (const std::string& w : s->warnings)
      EXPECT_NE(w.rfind("splined_model", 0), 0u) << "seed " << seed << ": " << w;
    EXPECT_EQ(s->cameras[1].model.lensmodel, "LENSMODEL_STEREOGRAPHIC");
    for (int c = 1; c < 4; ++c) {
      const RigCamera& cam = s->cameras[c];
      const double baseline_m = cam.baseline_m;
      const Rt exact = testing::rt_nearest(truth[c].rt_cam_ref, cam.rt_cam_ref);
      for (int k = 0; k < 6; ++k) {
        const double error = cam.rt_cam_ref[k] - exact[k];
        const double sigma = std::sqrt(cam.rt_covariance[7 * k]);
        z.push_back(error / sigma);
        beyond += std::abs(error) > 2 * sigma;
        if (k < 3) {
          const double error_deg = std::abs(error) * 180 / M_PI;
          worst_rotation_deg = std::max(worst_rotation_deg, error_deg);
          worst_rotation_sigmas = std::max(worst_rotation_sigmas, std::abs(error) / sigma);
          EXPECT_TRUE(error_deg <= 0.005 || std::abs(error) <= 3 * sigma)
              << "seed " << seed << " camera " << c << " rotation " << k << ": " << error_deg
              << " deg, sigma " << sigma * 180 / M_PI;
        } else {
          EXPECT_TRUE(std::abs(error) <= 0.05e-3 * baseline_m || std::abs(error) <= 3 * sigma)
              << "seed " << seed << " camera " << c << " translation " << k - 3 << ": "
              << error * 1000 << " mm, sigma " << sigma * 1000;
        }
      }
    }
  }
  double sum_sq = 0;
  for (double v : z) sum_sq += v * v;
  const double rms = std::sqrt(sum_sq / z.size());
  std::printf(
      "ring of 4 with a fisheye, a model per camera, 50 views, %d seeds: solve %.2f s, "
      "|error|/sigma RMS %.3f, %d of %zu beyond 2 sigma; worst rotation %.4f deg (%.2f "
      "sigma)\n",
      seeds, solve_s, rms, beyond, z.size(), worst_rotation_deg, worst_rotation_sigmas);
  // 108 normalised errors: their RMS within the 0.8-1.25 widened by its sampling
  // spread (about 0.07 at this count).
  EXPECT_GT(rms, 0.7);
  EXPECT_LT(rms, 1.35);
}

// Two 180 deg fisheyes 60 deg apart whose views of the board are partial (corners off
// either imager), so the two cameras see different corner counts in shared views. camlab
// solves them as they are. OpenCV 4.6's fisheye stereo calibration, given the same views
// (and the lenses' focal length and centre, held), refuses them: its extrinsic
// initialisation calls the first board "ill-conditioned" (CALIB_CHECK_COND).
TEST(RigSolve, AFisheyePairWithPartialViewsSolvesWhereOpenCvRefuses) {
  auto truth = testing::ring_with_fisheye_truth(60, 1);
  truth.resize(2);
  truth[0].lens = truth[1].lens;
  testing::RigViewSpec spec;
  spec.views = 40;
  spec.distance_min_m = 0.4;
  spec.distance_max_m = 1.0;
  const RigData data = testing::make_rig_views(truth, kBoard, spec);
  int unequal = 0;
  for (size_t v = 0; v < data.cameras[0].views.size(); ++v) {
    const int a = data.cameras[0].views[v].present_count(),
              b = data.cameras[1].views[v].present_count();
    unequal += a > 0 && b > 0 && a != b;
  }
  RigSolveOptions options;
  options.lensmodels = {"LENSMODEL_STEREOGRAPHIC", "LENSMODEL_STEREOGRAPHIC"};
  auto s = solve_rig(data, options);
  ASSERT_TRUE(s.ok()) << s.error().message;
  const RigCamera& cam = s->cameras[1];
  const Rt exact = testing::rt_nearest(truth[1].rt_cam_ref, cam.rt_cam_ref);
  std::printf(
      "fisheye pair, %d shared views with unequal corner counts: rotation error %.4f deg, "
      "baseline %.3f +- %.3f mm\n",
      unequal, rotation_between_deg(cam.rt_cam_ref, exact), cam.baseline_m * 1000,
      cam.baseline_sigma_mm);
  EXPECT_GE(unequal, 5);
  for (int k = 0; k < 6; ++k)
    EXPECT_LT(std::abs(cam.rt_cam_ref[k] - exact[k]), 3 * std::sqrt(cam.rt_covariance[7 * k]))
        << "component " << k;
  // OpenCV's fisheye stereo calibration on the same views, each camera's corners as it saw
  // them: refused.
  std::vector<std::vector<cv::Point3d>> object;
  std::vector<std::vector<cv::Point2d>> left, right;
  for (size_t v = 0; v < data.cameras[0].views.size(); ++v) {
    std::vector<cv::Point3d> o;
    std::vector<cv::Point2d> l, r;
    for (int k = 0; k < kBoard.cols * kBoard.rows; ++k) {
      const auto& a = data.cameras[0].views[v].corners[k];
      const auto& b = data.cameras[1].views[v].corners[k];
      if (a.present) l.emplace_back(a.x_px, a.y_px);
      if (b.present) r.emplace_back(b.x_px, b.y_px);
      if (a.present)
        o.emplace_back((k % kBoard.cols) * kBoard.spacing_m, (k / kBoard.cols) * kBoard.spacing_m,
                       0);
    }
    if (l.size() < 8 || r.size() < 8) continue;
    object.push_back(o);
    left.push_back(l);
    right.push_back(r);
  }
  cv::Matx33d k0 = cv::Matx33d::eye(), k1 = cv::Matx33d::eye(), rotation;
  cv::Vec4d d0, d1;
  cv::Vec3d translation;
  bool refused = false;
  try {
    k0 = k1 = cv::Matx33d(320, 0, 639.5, 0, 320, 399.5, 0, 0, 1);
    cv::fisheye::stereoCalibrate(object, left, right, k0, d0, k1, d1, {1280, 800}, rotation,
                                 translation, cv::fisheye::CALIB_FIX_INTRINSIC);
  } catch (const cv::Exception& e) {
    refused = true;
    std::printf("OpenCV's fisheye::stereoCalibrate: %s\n", e.what());
  }
  EXPECT_TRUE(refused) << "OpenCV took point lists of unequal lengths";
}

// A detector that names a plain board's corners from the other end in some views of one
// camera (and a quarter turn for a square board): the solve re-labels those views and
// reaches the solve of the data labelled alike.
TEST(RigSolve, ViewsLabelledTurnedInOneCameraAreRelabelled) {
  for (const BoardSpec board : {kBoard, BoardSpec{8, 8, 0.05}}) {
    const auto truth = stereo_pair_truth();
    testing::RigViewSpec spec;
    spec.seed = 5;
    const RigData data = testing::make_rig_views(truth, board, spec);
    RigData turned = data;
    const int quarter = board.cols == board.rows ? 1 : 2;
    std::vector<int> turned_views;
    for (size_t v = 0; v < turned.cameras[1].views.size() && turned_views.size() < 4; ++v)
      if (turned.cameras[1].views[v].present_count() > 0 &&
          turned.cameras[0].views[v].present_count() > 0) {
        turned.cameras[1].views[v] = turned_view(turned.cameras[1].views[v], board, quarter);
        turned_views.push_back(static_cast<int>(v));
      }
    RigSolveOptions options;
    options.lensmodel = "LENSMODEL_OPENCV4";
    auto alike = solve_rig(data, options);
    auto relabelled = solve_rig(turned, options);
    ASSERT_TRUE(alike.ok() && relabelled.ok());
    EXPECT_EQ(relabelled->label_turns[1].size(), turned_views.size()) << board.cols;
    for (int v : turned_views) EXPECT_TRUE(relabelled->label_turns[1].count(v)) << v;
    EXPECT_LT(rotation_between_deg(alike->cameras[1].rt_cam_ref, relabelled->cameras[1].rt_cam_ref),
              1e-6);
    EXPECT_EQ(relabelled->cameras[1].outliers, alike->cameras[1].outliers);
  }
}

// Each camera's data judged as one camera's: 6 views, and boards that all face camera 0,
// are warned about with the camera's number, and the solve still answers.
TEST(RigSolve, EachCamerasDegenerateDataIsWarnedAboutByNumber) {
  testing::RigViewSpec spec;
  spec.views = 6;
  spec.max_tilt_deg = 6;
  const RigData data = testing::make_rig_views(stereo_pair_truth(), kBoard, spec);
  RigSolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV4";
  auto s = solve_rig(data, options);
  ASSERT_TRUE(s.ok()) << s.error().message;
  std::string all;
  for (const std::string& w : s->warnings) all += w + "\n";
  // Boards facing camera 0 within 6 deg; camera 1, 0.2 m to its side, sees them turned.
  for (const char* expected :
       {"camera 0: too_few_views", "camera 1: too_few_views", "camera 0: fronto_parallel"})
    EXPECT_NE(all.find(expected), std::string::npos) << expected << " in\n" << all;
}

TEST(RigSolve, ACameraThatSharesNoViewIsRefusedWithItsNumber) {
  auto truth = stereo_pair_truth();
  // Camera 1 turned 180 deg: it never sees a board camera 0 sees.
  truth[1].rt_cam_ref = {0, M_PI, 0, 0, 0, 0};
  testing::RigViewSpec spec;
  const RigData data = testing::make_rig_views(truth, kBoard, spec);
  RigSolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV4";
  auto s = solve_rig(data, options);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().text().rfind("too_few_views", 0), 0u) << s.error().text();
  EXPECT_NE(s.error().message.find("camera 1"), std::string::npos) << s.error().message;
}

TEST(RigSolve, MisalignedViewsAndTooManyCamerasAreRefused) {
  const auto truth = stereo_pair_truth();
  testing::RigViewSpec spec;
  spec.views = 6;
  RigData data = testing::make_rig_views(truth, kBoard, spec);
  data.cameras[1].views.pop_back();
  auto s = solve_rig(data, RigSolveOptions{});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().text().find("invalid_argument"), std::string::npos);
  EXPECT_NE(s.error().message.find("camera 1 has 5 views"), std::string::npos) << s.error().message;
  RigData many;
  many.cameras.assign(9, data.cameras[0]);
  auto too_many = solve_rig(many, RigSolveOptions{});
  ASSERT_FALSE(too_many.ok());
  EXPECT_NE(too_many.error().message.find("not 9"), std::string::npos) << too_many.error().message;
}

}  // namespace rig_solver_test
}  // namespace
}  // namespace camlab::calib
