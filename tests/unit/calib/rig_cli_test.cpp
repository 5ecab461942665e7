// `camlab calibrate --rig` end to end on a synthetic pair's corners (corners.vnl, one a
// camera): the files mrcal's tools read, and what mrcal itself reads from them.
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/format.h"
#include "calib/corners/corners_vnl.h"
#include "calib/rig/rig_pose.h"
#include "synthetic_rig.h"
#include "tests/integration/cli_runner.h"

namespace camlab::calib {
namespace {
namespace rig_cli_test {

namespace fs = std::filesystem;
using camlab::testing::run_cli;

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("camlab_rig_cli_" + std::to_string(getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
};

// The pair of rig_solver_test.cpp, written as one corners.vnl a camera, the views named
// camN/viewK.png (the rig matches them by viewK.png).
// `seed` draws the poses and noise; `camera1_yaw_deg` turns camera 1 further.
void write_rig_corners(const fs::path& dir, const std::vector<testing::RigCameraTruth>& truth,
                       const testing::RigViewSpec& spec) {
  RigData data = testing::make_rig_views(truth, BoardSpec{10, 7, 0.05}, spec);
  for (size_t c = 0; c < truth.size(); ++c) {
    std::vector<BoardView> seen;
    for (size_t v = 0; v < data.cameras[c].views.size(); ++v) {
      BoardView view = data.cameras[c].views[v];
      if (view.present_count() == 0) continue;
      view.name = "cam" + std::to_string(c) + "/view" + std::to_string(v) + ".png";
      seen.push_back(view);
    }
    std::ofstream(dir / ("cam" + std::to_string(c) + ".vnl")) << to_corners_vnl(seen);
  }
}

std::vector<testing::RigCameraTruth> write_pair_corners(const fs::path& dir, uint32_t seed = 7,
                                                        double camera1_yaw_deg = 0) {
  const auto truth = testing::stereo_pair_truth(camera1_yaw_deg);
  testing::RigViewSpec spec;
  spec.seed = seed;
  write_rig_corners(dir, truth, spec);
  return truth;
}

TEST(RigCli, WritesCameraModelsMrcalReadsWithTheTruthsExtrinsics) {
  TempDir tmp;
  const auto truth = write_pair_corners(tmp.path);
  const fs::path out = tmp.path / "rig";
  const auto run = run_cli("calibrate --rig --corners " + (tmp.path / "cam0.vnl").string() +
                           " --corners " + (tmp.path / "cam1.vnl").string() +
                           " --imager 640x480 --imager 1280x800 --board 10x7 --spacing-m 0.05 "
                           "--model LENSMODEL_OPENCV4 --range-m 3 --json --out " +
                           out.string());
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const auto report = nlohmann::json::parse(run.out);
  const auto& range = report["range_uncertainty"][0];
  ASSERT_TRUE(range.contains("sigma_mm")) << range.dump();
  EXPECT_EQ(range["range_m"], 3.0);
  EXPECT_GT(range["sigma_mm"].get<double>(), 0);
  const auto& b = report["cameras"][1];
  const Rt rt = b["rt_cam_ref"].get<Rt>();
  const double rotation_deg = rotation_between_deg(rt, truth[1].rt_cam_ref);
  const auto sigma_deg = b["rotation_sigma_deg"].get<std::vector<double>>();
  std::printf("rotation error %.5f deg (sigma %.5f %.5f %.5f), baseline %.3f +- %.3f mm\n",
              rotation_deg, sigma_deg[0], sigma_deg[1], sigma_deg[2],
              b["baseline_m"].get<double>() * 1000, b["baseline_sigma_mm"].get<double>());
  EXPECT_LT(rotation_deg, 3 * std::hypot(sigma_deg[0], sigma_deg[1], sigma_deg[2]));
  EXPECT_EQ(report["cameras"][0]["imager_px"], nlohmann::json({640, 480}));
  EXPECT_EQ(report["cameras"][1]["imager_px"], nlohmann::json({1280, 800}));
  for (const char* file : {"camera-0.cameramodel", "camera-1.cameramodel", "rig.json"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
  // mrcal reads the models: camera 1's extrinsics are the report's, camera 0 the reference.
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "Debian's python3 (with mrcal) is absent";
  const fs::path script = tmp.path / "read.py";
  std::ofstream(script) << "import mrcal, sys\n"
                           "for f in sys.argv[1:]:\n"
                           "    m = mrcal.cameramodel(f)\n"
                           "    print(' '.join('%.12g' % v for v in m.extrinsics_rt_fromref()),\n"
                           "          m.imagersize()[0], m.imagersize()[1])\n";
  const std::string command = "/usr/bin/python3 " + script.string() + " " +
                              (out / "camera-0.cameramodel").string() + " " +
                              (out / "camera-1.cameramodel").string();
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  double v[2][8] = {};
  for (auto& row : v)
    for (double& x : row) ASSERT_EQ(std::fscanf(pipe, "%lf", &x), 1);
  ASSERT_EQ(pclose(pipe), 0);
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(v[0][k], 0.0);
    EXPECT_NEAR(v[1][k], rt[k], 1e-9);
  }
  EXPECT_EQ(v[1][6], 1280);
  EXPECT_EQ(v[1][7], 800);
}

// `--model auto` on a wide lens beside a 180 deg fisheye (the issue's ring, its first two
// cameras): each camera keeps its own selection, the fisheye STEREOGRAPHIC and the wide lens
// an OpenCV model, the pair is solved together without the splined model, and mrcal reads
// both files with their models.
TEST(RigCli, AutoKeepsEachCamerasOwnModelBesideAFisheye) {
  TempDir tmp;
  auto truth = testing::ring_with_fisheye_truth(60, 1);
  truth.resize(2);
  testing::RigViewSpec spec;
  spec.views = 30;
  spec.distance_min_m = 0.6;
  spec.distance_max_m = 1.4;
  write_rig_corners(tmp.path, truth, spec);
  const fs::path out = tmp.path / "rig";
  const auto run = run_cli("calibrate --rig --corners " + (tmp.path / "cam0.vnl").string() +
                           " --corners " + (tmp.path / "cam1.vnl").string() +
                           " --imager 1280x800 --imager 1280x800 --board 10x7 --spacing-m 0.05 "
                           "--model auto --json --out " +
                           out.string());
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const auto report = nlohmann::json::parse(run.out);
  const auto& cameras = report["cameras"];
  const std::string wide = cameras[0]["lensmodel"], fisheye = cameras[1]["lensmodel"];
  std::printf("own models: %s, %s\n", wide.c_str(), fisheye.c_str());
  EXPECT_EQ(wide.rfind("LENSMODEL_OPENCV", 0), 0u) << wide;
  EXPECT_EQ(fisheye, "LENSMODEL_STEREOGRAPHIC");
  EXPECT_EQ(cameras[0]["own_lensmodel"], wide);
  EXPECT_EQ(cameras[1]["own_lensmodel"], fisheye);
  for (const auto& w : report["warnings"])
    EXPECT_EQ(w.get<std::string>().find("splined"), std::string::npos) << w;
  const Rt rt = cameras[1]["rt_cam_ref"].get<Rt>();
  const double rotation_deg = rotation_between_deg(rt, truth[1].rt_cam_ref);
  const auto sigma_deg = cameras[1]["rotation_sigma_deg"].get<std::vector<double>>();
  const double baseline_mm = cameras[1]["baseline_m"].get<double>() * 1000;
  const double baseline_sigma_mm = cameras[1]["baseline_sigma_mm"].get<double>();
  const cv::Matx44d pose = testing::rt_matrix(truth[1].rt_cam_ref).inv();
  const double truth_mm = 1000 * std::hypot(pose(0, 3), pose(1, 3), pose(2, 3));
  std::printf(
      "fisheye: rotation error %.4f deg (sigma %.4f %.4f %.4f), baseline %.3f +- %.3f mm "
      "(truth %.3f)\n",
      rotation_deg, sigma_deg[0], sigma_deg[1], sigma_deg[2], baseline_mm, baseline_sigma_mm,
      truth_mm);
  EXPECT_LT(rotation_deg, 3 * std::hypot(sigma_deg[0], sigma_deg[1], sigma_deg[2]));
  EXPECT_LT(std::abs(baseline_mm - truth_mm), 3 * baseline_sigma_mm);
  // The pair rectified across both models: the calibration's corners on common rows.
  const auto& rectified = report["rectification"][0];
  ASSERT_TRUE(rectified["epipolar"].contains("rms_px")) << rectified.dump();
  std::printf("rectified (%s, fx %.1f px): epipolar residual %.3f px RMS over %d corners\n",
              rectified["rectified_lensmodel"].get<std::string>().c_str(),
              rectified["rectified_intrinsics"][0].get<double>(),
              rectified["epipolar"]["rms_px"].get<double>(),
              rectified["epipolar"]["corners"].get<int>());
  // The corners' own 0.3 px noise, the fisheye's magnified about 2x in the rectified frame
  // (its 320 px focal length against the rectified one), gives about 0.7 px; a wrong model
  // or pose gives tens.
  EXPECT_LT(rectified["epipolar"]["rms_px"].get<double>(), 1.5);
  // The two models read back by `camlab stereo triangulate`: a point 1.5 m along camera 0's
  // axis (55 deg off the fisheye's) from its true pixels, within the stated sigma, which
  // carries the calibration's covariance of both models (19 parameters).
  const cv::Vec3d p0(0.05, -0.03, 1.5);
  const cv::Vec4d p1 = testing::rt_matrix(truth[1].rt_cam_ref) * cv::Vec4d(p0[0], p0[1], p0[2], 1);
  const auto q0 = project(truth[0].lens, {p0[0], p0[1], p0[2]});
  const auto q1 = project(truth[1].lens, {p1[0], p1[1], p1[2]});
  ASSERT_TRUE(q0.ok() && q1.ok());
  const auto triangulated = run_cli(
      "stereo triangulate --rig " + out.string() +
      format_printf(" --pixels %.6f,%.6f,%.6f,%.6f", (*q0)[0], (*q0)[1], (*q1)[0], (*q1)[1]) +
      " --pixel-sigma 0 --json");
  ASSERT_EQ(triangulated.exit_code, 0) << triangulated.err << triangulated.out;
  const auto point = nlohmann::json::parse(triangulated.out);
  EXPECT_TRUE(point["calibration_uncertainty"].get<bool>());
  const double range_error_mm = (point["points"][0]["range_m"].get<double>() - cv::norm(p0)) * 1000;
  const double range_sigma_mm = point["points"][0]["range_sigma_mm"].get<double>();
  std::printf(
      "a point %.3f m away through the wide lens and the fisheye: error %.3f mm (sigma "
      "%.3f mm)\n",
      cv::norm(p0), range_error_mm, range_sigma_mm);
  EXPECT_GT(range_sigma_mm, 0);
  EXPECT_LT(std::abs(range_error_mm), 3 * range_sigma_mm);
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "Debian's python3 (with mrcal) is absent";
  const fs::path script = tmp.path / "read.py";
  std::ofstream(script) << "import mrcal, sys\n"
                           "for f in sys.argv[1:]:\n"
                           "    print(mrcal.cameramodel(f).intrinsics()[0])\n";
  const std::string command = "/usr/bin/python3 " + script.string() + " " +
                              (out / "camera-0.cameramodel").string() + " " +
                              (out / "camera-1.cameramodel").string();
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char names[2][128] = {};
  for (auto& name : names) ASSERT_EQ(std::fscanf(pipe, "%127s", name), 1);
  ASSERT_EQ(pclose(pipe), 0);
  EXPECT_EQ(std::string(names[0]), wide);
  EXPECT_EQ(std::string(names[1]), fisheye);
}

// mrcal's own tool on the same corners (one corners.vnl, the cameras told apart by their
// folders, blank images of each imager's size for the tool to read the size from): both
// solve the same problem, so camlab's extrinsics must be as near the truth as mrcal's.
TEST(RigCli, AsNearTheTruthAsMrcalCalibrateCamerasOnTheSameCorners) {
  if (!fs::exists("/usr/bin/mrcal-calibrate-cameras"))
    GTEST_SKIP() << "mrcal-calibrate-cameras (Debian's mrcal) is absent";
  TempDir tmp;
  const auto truth = write_pair_corners(tmp.path);
  std::ofstream all(tmp.path / "all.vnl");
  for (int c = 0; c < 2; ++c) {
    const fs::path vnl = tmp.path / ("cam" + std::to_string(c) + ".vnl");
    auto views = read_corners_vnl(vnl, BoardSpec{10, 7, 0.05});
    ASSERT_TRUE(views.ok()) << views.error().message;
    fs::create_directories(tmp.path / ("cam" + std::to_string(c)));
    const cv::Mat blank = cv::Mat::zeros(truth[c].lens.height_px, truth[c].lens.width_px, CV_8U);
    for (const auto& v : *views) cv::imwrite((tmp.path / v.name).string(), blank);
    std::ifstream in(vnl);
    std::string line;
    while (std::getline(in, line))
      if (c == 0 || line.rfind("#", 0) != 0) all << line << "\n";
  }
  all.close();
  const fs::path ours = tmp.path / "ours", theirs = tmp.path / "theirs";
  const auto run = run_cli("calibrate --rig --corners " + (tmp.path / "cam0.vnl").string() +
                           " --corners " + (tmp.path / "cam1.vnl").string() +
                           " --imager 640x480 --imager 1280x800 --board 10x7 --spacing-m 0.05 "
                           "--model LENSMODEL_OPENCV4 --json --out " +
                           ours.string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  const Rt ours_rt = report["cameras"][1]["rt_cam_ref"].get<Rt>();
  fs::create_directories(theirs);
  const std::string command =
      "cd " + tmp.path.string() +
      " && /usr/bin/python3 /usr/bin/mrcal-calibrate-cameras --corners-cache all.vnl "
      "--lensmodel LENSMODEL_OPENCV4 --focal 600 --object-spacing 0.05 --object-width-n 10 "
      "--object-height-n 7 --outdir theirs 'cam0/*.png' 'cam1/*.png' > mrcal.log 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << "see " << (tmp.path / "mrcal.log");
  const std::string read_rt =
      "/usr/bin/python3 -c \"import mrcal; print(' '.join('%.15g' % v for v in "
      "mrcal.cameramodel('" +
      (theirs / "camera-1.cameramodel").string() + "').extrinsics_rt_fromref()))\"";
  FILE* pipe = popen(read_rt.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  Rt theirs_rt{};
  for (double& x : theirs_rt) ASSERT_EQ(std::fscanf(pipe, "%lf", &x), 1);
  ASSERT_EQ(pclose(pipe), 0);
  auto translation_mm = [&](const Rt& rt) {
    return 1000 * std::hypot(rt[3] - truth[1].rt_cam_ref[3], rt[4] - truth[1].rt_cam_ref[4],
                             rt[5] - truth[1].rt_cam_ref[5]);
  };
  const double ours_deg = rotation_between_deg(ours_rt, truth[1].rt_cam_ref);
  const double theirs_deg = rotation_between_deg(theirs_rt, truth[1].rt_cam_ref);
  const auto sigma = report["cameras"][1]["rotation_sigma_deg"].get<std::vector<double>>();
  const auto sigma_mm = report["cameras"][1]["translation_sigma_mm"].get<std::vector<double>>();
  std::printf(
      "against the truth: camlab %.5f deg %.4f mm, mrcal-calibrate-cameras %.5f deg "
      "%.4f mm; between them %.5f deg\n",
      ours_deg, translation_mm(ours_rt), theirs_deg, translation_mm(theirs_rt),
      rotation_between_deg(ours_rt, theirs_rt));
  EXPECT_LE(ours_deg, theirs_deg + 0.25 * std::hypot(sigma[0], sigma[1], sigma[2]));
  EXPECT_LE(translation_mm(ours_rt),
            translation_mm(theirs_rt) + 0.25 * std::hypot(sigma_mm[0], sigma_mm[1], sigma_mm[2]));
}

// A real stereo pair (OpenCV's sample, tests/data/real_photos/opencv_stereo_9x6: a
// hand-held pair of 640x480 cameras, 13 views of a 9x6 board, square size not published:
// taken as 25 mm) through `camlab calibrate --rig`, against OpenCV's own pipeline on the
// same photos: findChessboardCorners + cornerSubPix and stereoCalibrate with the same
// 4-parameter distortion. Two detectors and two solvers (camlab also fits the board's
// warp), so they agree to the data's uncertainty, not to the digit.
TEST(RigCli, RealStereoPairAgreesWithOpenCvsStereoCalibration) {
  const fs::path set = fs::path(CAMLAB_SOURCE_DIR) / "tests/data/real_photos/opencv_stereo_9x6";
  TempDir tmp;
  const auto run = run_cli("calibrate --rig --images '" + (set / "left*.jpg").string() +
                           "' --images '" + (set / "right*.jpg").string() +
                           "' --board 9x6 --spacing-m 0.025 --model LENSMODEL_OPENCV4 --json "
                           "--out " +
                           tmp.path.string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  ASSERT_EQ(report["views"].size(), 13u) << report["views"].dump();
  const auto& b = report["cameras"][1];
  const Rt rt = b["rt_cam_ref"].get<Rt>();

  const cv::Size pattern(9, 6);
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> left, right;
  std::vector<cv::Point3f> board;
  for (int j = 0; j < 6; ++j)
    for (int i = 0; i < 9; ++i) board.emplace_back(i * 0.025f, j * 0.025f, 0.f);
  for (const auto& key : report["views"]) {
    std::vector<cv::Point2f> corners[2];
    bool found = true;
    for (int c = 0; c < 2; ++c) {
      const cv::Mat image = cv::imread(
          (set / ((c == 0 ? "left" : "right") + key.get<std::string>() + ".jpg")).string(),
          cv::IMREAD_GRAYSCALE);
      found = found && cv::findChessboardCorners(image, pattern, corners[c]);
      if (found)
        cv::cornerSubPix(image, corners[c], {5, 5}, {-1, -1},
                         {cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3});
    }
    if (!found) continue;
    object.push_back(board);
    left.push_back(corners[0]);
    right.push_back(corners[1]);
  }
  ASSERT_GE(left.size(), 10u);
  cv::Mat k0, d0, k1, d1, R, T, E, F;
  const double rms = cv::stereoCalibrate(object, left, right, k0, d0, k1, d1, {640, 480}, R, T, E,
                                         F, cv::CALIB_FIX_K3);
  cv::Vec3d r;
  cv::Rodrigues(R, r);
  const Rt opencv_rt{r[0], r[1], r[2], T.at<double>(0), T.at<double>(1), T.at<double>(2)};
  const double baseline_mm = b["baseline_m"].get<double>() * 1000;
  const double opencv_baseline_mm = cv::norm(T) * 1000;
  const double rotation_apart_deg = rotation_between_deg(rt, opencv_rt);
  std::printf(
      "real pair (OpenCV's sample, %zu views in both): camlab baseline %.2f +- %.3f mm, "
      "OpenCV stereoCalibrate %.2f mm (RMS %.3f px); rotations %.4f deg apart; "
      "camlab's 1-sigma rotation %.4f/%.4f/%.4f deg\n",
      left.size(), baseline_mm, b["baseline_sigma_mm"].get<double>(), opencv_baseline_mm, rms,
      rotation_apart_deg, b["rotation_sigma_deg"][0].get<double>(),
      b["rotation_sigma_deg"][1].get<double>(), b["rotation_sigma_deg"][2].get<double>());
  EXPECT_NEAR(baseline_mm, opencv_baseline_mm, 0.005 * opencv_baseline_mm);
  EXPECT_LT(rotation_apart_deg, 0.2);
  EXPECT_LT(report["rms_px"].get<double>(), 0.3);
  // One view of the right camera is labelled 180 deg turned by the detector: re-labelled,
  // not thrown out (a whole view of outliers before the re-labelling).
  for (const auto& camera : report["cameras"]) EXPECT_LT(camera["outliers"].get<int>(), 10);
  const auto& epipolar = report["rectification"][0]["epipolar"];
  std::printf("real pair rectified: epipolar residual %.3f px RMS over %d corners\n",
              epipolar["rms_px"].get<double>(), epipolar["corners"].get<int>());
  EXPECT_LT(epipolar["rms_px"].get<double>(), 0.3);

  // `camlab stereo triangulate` on OpenCV's refined corners of each view: the board's
  // outer corners come back its size apart (8 x 25 mm along a row, 5 x 25 mm down a column).
  // Even views through --pixels, odd ones through a matches file.
  double worst_mm = 0;
  for (size_t v = 0; v < left.size(); ++v) {
    std::string pixels, matches = "# x0 y0 x1 y1: OpenCV's corners 0, 8, 45 and 53\n";
    for (int k : {0, 8, 45, 53}) {
      pixels += format_printf(" --pixels %.4f,%.4f,%.4f,%.4f", left[v][k].x, left[v][k].y,
                              right[v][k].x, right[v][k].y);
      matches += format_printf("%.4f %.4f\t%.4f %.4f\n", left[v][k].x, left[v][k].y, right[v][k].x,
                               right[v][k].y);
    }
    const fs::path matches_file = tmp.path / "matches.txt";
    std::ofstream(matches_file) << matches;
    const std::string source = v % 2 ? " --matches " + matches_file.string() : pixels;
    const auto tri = run_cli("stereo triangulate --rig " + tmp.path.string() + source + " --json");
    ASSERT_EQ(tri.exit_code, 0) << tri.err << tri.out;
    const auto points = nlohmann::json::parse(tri.out)["points"];
    auto at = [&](int i) {
      return cv::Vec3d(points[i]["point_m"].get<std::array<double, 3>>().data());
    };
    const double row_mm = cv::norm(at(1) - at(0)) * 1000, row2_mm = cv::norm(at(3) - at(2)) * 1000;
    const double column_mm = cv::norm(at(2) - at(0)) * 1000,
                 column2_mm = cv::norm(at(3) - at(1)) * 1000;
    worst_mm = std::max({worst_mm, std::abs(row_mm - 200), std::abs(row2_mm - 200),
                         std::abs(column_mm - 125), std::abs(column2_mm - 125)});
    std::printf("view %zu at %.2f m: rows %.2f and %.2f mm (200), columns %.2f and %.2f mm (125)\n",
                v, points[0]["range_m"].get<double>(), row_mm, row2_mm, column_mm, column2_mm);
  }
  EXPECT_LT(worst_mm, 1.5);
}

// Three calibrations: the rig, the same rig with fresh views, and the rig with camera 1
// turned 0.5 deg (about 8 sigmas of the two calibrations together; 0.2 deg, 3 sigmas, is
// not told from noise). --drift-from tells the second unchanged and the
// third moved.
TEST(RigCli, DriftFromAnEarlierCalibrationSeesATurnAndNotTheNoise) {
  TempDir tmp;
  auto calibrate = [&](const std::string& name, uint32_t seed, double yaw_deg,
                       const std::string& drift_from) {
    const fs::path dir = tmp.path / name;
    fs::create_directories(dir);
    write_pair_corners(dir, seed, yaw_deg);
    return run_cli("calibrate --rig --corners " + (dir / "cam0.vnl").string() + " --corners " +
                   (dir / "cam1.vnl").string() +
                   " --imager 640x480 --imager 1280x800 --board 10x7 --spacing-m 0.05 "
                   "--model LENSMODEL_OPENCV4 --json --out " +
                   (dir / "rig").string() +
                   (drift_from.empty() ? "" : " --drift-from " + drift_from));
  };
  const auto first = calibrate("first", 7, 0, "");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const std::string before = (tmp.path / "first" / "rig" / "rig.json").string();
  const auto again = calibrate("again", 8, 0, before);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const auto turned = calibrate("turned", 9, 0.5, before);
  ASSERT_EQ(turned.exit_code, 0) << turned.err;
  const auto unchanged = nlohmann::json::parse(again.out)["drift"]["cameras"][0];
  const auto moved = nlohmann::json::parse(turned.out)["drift"]["cameras"][0];
  std::printf(
      "same rig: %s, chi-square %.1f, %.4f deg; turned 0.5 deg: %s, chi-square %.1f, "
      "%.4f deg\n",
      unchanged["verdict"].get<std::string>().c_str(), unchanged["chi_square"].get<double>(),
      unchanged["rotation_deg"].get<double>(), moved["verdict"].get<std::string>().c_str(),
      moved["chi_square"].get<double>(), moved["rotation_deg"].get<double>());
  EXPECT_EQ(unchanged["verdict"], "unchanged");
  EXPECT_EQ(moved["verdict"], "moved");
  EXPECT_NEAR(moved["rotation_deg"].get<double>(), 0.5, 0.15);
  const auto bad = run_cli(
      "calibrate --rig --corners " + (tmp.path / "first" / "cam0.vnl").string() + " --corners " +
      (tmp.path / "first" / "cam1.vnl").string() +
      " --imager 640x480 --imager 1280x800 --board 10x7 --spacing-m 0.05 "
      "--model LENSMODEL_OPENCV4 --out " +
      (tmp.path / "x").string() + " --drift-from " + (tmp.path / "first" / "cam0.vnl").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_NE(bad.err.find("not JSON"), std::string::npos) << bad.err;
}

TEST(RigCli, RefusesMixedSourcesAndAMissingImager) {
  TempDir tmp;
  write_pair_corners(tmp.path);
  const auto mixed =
      run_cli("calibrate --rig --corners " + (tmp.path / "cam0.vnl").string() + " --images " +
              tmp.path.string() + " --board 10x7 --spacing-m 0.05 --out " + tmp.path.string());
  EXPECT_EQ(mixed.exit_code, 2) << mixed.err;
  EXPECT_NE(mixed.err.find("one kind of source"), std::string::npos) << mixed.err;
  const auto no_imager = run_cli("calibrate --rig --corners " + (tmp.path / "cam0.vnl").string() +
                                 " --corners " + (tmp.path / "cam1.vnl").string() +
                                 " --board 10x7 --spacing-m 0.05 --out " + tmp.path.string());
  EXPECT_EQ(no_imager.exit_code, 2) << no_imager.err;
  EXPECT_NE(no_imager.err.find("--imager"), std::string::npos) << no_imager.err;
  const auto two_without_rig =
      run_cli("calibrate --corners " + (tmp.path / "cam0.vnl").string() + " --corners " +
              (tmp.path / "cam1.vnl").string() +
              " --imager 640x480 --board 10x7 --spacing-m 0.05 --out x.cameramodel");
  EXPECT_EQ(two_without_rig.exit_code, 2) << two_without_rig.err;
  EXPECT_NE(two_without_rig.err.find("--rig"), std::string::npos) << two_without_rig.err;
}

// Points in camera 0's frame (m) that both cameras of the pair see.
const std::vector<cv::Vec3d> kStereoPoints = {
    {-0.2, -0.1, 1.5}, {0.1, 0.15, 2.5}, {0.05, 0.0, 4.0}};

// A point's true pixels in camera 0 and camera 1 of the pair.
std::array<double, 4> true_pixels(const std::vector<testing::RigCameraTruth>& truth,
                                  const cv::Vec3d& p0) {
  const cv::Vec4d p1 = testing::rt_matrix(truth[1].rt_cam_ref) * cv::Vec4d(p0[0], p0[1], p0[2], 1);
  auto q0 = project(truth[0].lens, {p0[0], p0[1], p0[2]});
  auto q1 = project(truth[1].lens, {p1[0], p1[1], p1[2]});
  EXPECT_TRUE(q0.ok() && q1.ok());
  return {(*q0)[0], (*q0)[1], (*q1)[0], (*q1)[1]};
}

// The pair's corners in `dir` (write_pair_corners) calibrated into the rig folder `rig`.
void calibrate_pair(const fs::path& dir, const fs::path& rig) {
  const auto run = run_cli("calibrate --rig --corners " + (dir / "cam0.vnl").string() +
                           " --corners " + (dir / "cam1.vnl").string() +
                           " --imager 640x480 --imager 1280x800 --board 10x7 --spacing-m 0.05 "
                           "--model LENSMODEL_OPENCV4 --out " +
                           rig.string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
}

// `camlab stereo triangulate` on the calibrated pair: the true pixels of known points give
// the points back within the uncertainty the calibration states (the pixels exact, so the
// calibration's part alone), and a pixel noise adds its own part.
TEST(RigCli, StereoTriangulateGivesTheTruthWithinTheStatedSigma) {
  TempDir tmp;
  const auto truth = write_pair_corners(tmp.path);
  const fs::path rig = tmp.path / "rig";
  ASSERT_NO_FATAL_FAILURE(calibrate_pair(tmp.path, rig));
  std::string pixels;
  for (const cv::Vec3d& p : kStereoPoints) {
    const auto q = true_pixels(truth, p);
    pixels += format_printf(" --pixels %.6f,%.6f,%.6f,%.6f", q[0], q[1], q[2], q[3]);
  }
  const auto run =
      run_cli("stereo triangulate --rig " + rig.string() + pixels + " --pixel-sigma 0 --json");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const auto out = nlohmann::json::parse(run.out);
  EXPECT_TRUE(out["calibration_uncertainty"].get<bool>());
  ASSERT_EQ(out["points"].size(), kStereoPoints.size());
  for (size_t i = 0; i < kStereoPoints.size(); ++i) {
    const auto& j = out["points"][i];
    const auto p = j["point_m"].get<std::array<double, 3>>();
    const double range_error_mm = (j["range_m"].get<double>() - cv::norm(kStereoPoints[i])) * 1000;
    const double sigma_mm = j["range_sigma_mm"].get<double>();
    std::printf("point %zu: range %.4f m, error %.3f mm, sigma %.3f mm; rays %.4f mm apart\n", i,
                j["range_m"].get<double>(), range_error_mm, sigma_mm, j["miss_mm"].get<double>());
    EXPECT_EQ(j["range_sigma_pixels_mm"].get<double>(), 0.0);
    EXPECT_NEAR(j["range_sigma_calibration_mm"].get<double>(), sigma_mm, 1e-9);
    EXPECT_GT(sigma_mm, 0);
    EXPECT_LT(std::abs(range_error_mm), 3 * sigma_mm);
    const auto axis_sigma = j["point_sigma_mm"].get<std::array<double, 3>>();
    for (int k = 0; k < 3; ++k)
      EXPECT_LT(std::abs(p[k] - kStereoPoints[i][k]) * 1000, 3 * axis_sigma[k] + 1e-3)
          << "point " << i << " axis " << k;
  }
  // Half a pixel of matching noise: its part grows with the range squared over the baseline.
  const auto noisy =
      run_cli("stereo triangulate --rig " + rig.string() + pixels + " --pixel-sigma 0.5 --json");
  ASSERT_EQ(noisy.exit_code, 0) << noisy.err;
  const auto noisy_points = nlohmann::json::parse(noisy.out)["points"];
  const double near_mm = noisy_points[0]["range_sigma_pixels_mm"].get<double>();
  const double far_mm = noisy_points[2]["range_sigma_pixels_mm"].get<double>();
  std::printf("0.5 px of matching noise: %.2f mm at %.2f m, %.2f mm at %.2f m\n", near_mm,
              cv::norm(kStereoPoints[0]), far_mm, cv::norm(kStereoPoints[2]));
  const double squared = std::pow(cv::norm(kStereoPoints[2]) / cv::norm(kStereoPoints[0]), 2);
  EXPECT_GT(far_mm / near_mm, 0.6 * squared);
  EXPECT_LT(far_mm / near_mm, 1.6 * squared);
  // Pixels that are no match: rays behind a camera, or the wrong count of numbers.
  const auto wrong = run_cli("stereo triangulate --rig " + rig.string() +
                             " --pixels 10,240,1270,400 --pixel-sigma 0 --json");
  EXPECT_EQ(wrong.exit_code, 2) << wrong.out;
  EXPECT_NE(wrong.out.find("projection_failed"), std::string::npos) << wrong.out;
  const auto odd = run_cli("stereo triangulate --rig " + rig.string() + " --pixels 1,2,3 --json");
  EXPECT_EQ(odd.exit_code, 2);
  EXPECT_NE(odd.out.find("invalid_argument"), std::string::npos) << odd.out;
  std::ofstream(tmp.path / "bad_matches.txt") << "# fine\n1 2 3 4\n1 2 3\n";
  const auto bad = run_cli("stereo triangulate --rig " + rig.string() + " --matches " +
                           (tmp.path / "bad_matches.txt").string() + " --json");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.out.find("bad_matches.txt:3"), std::string::npos) << bad.out;
}

// `camlab stereo rectify`: blobs drawn at the true pixels of known points in each camera's
// image land on one row in the two rectified images, their disparity f B / z.
TEST(RigCli, StereoRectifyPutsEachPointOnOneRow) {
  TempDir tmp;
  const auto truth = write_pair_corners(tmp.path);
  const fs::path rig = tmp.path / "rig";
  ASSERT_NO_FATAL_FAILURE(calibrate_pair(tmp.path, rig));
  // 16-bit images, blob i peaking at 10000 (i + 1) DN, a Gaussian of 2.5 px.
  cv::Mat images[2] = {cv::Mat::zeros(480, 640, CV_16UC1), cv::Mat::zeros(800, 1280, CV_16UC1)};
  for (size_t i = 0; i < kStereoPoints.size(); ++i) {
    const auto q = true_pixels(truth, kStereoPoints[i]);
    for (int c = 0; c < 2; ++c)
      for (int y = 0; y < images[c].rows; ++y)
        for (int x = 0; x < images[c].cols; ++x) {
          const double d2 = std::pow(x - q[2 * c], 2) + std::pow(y - q[2 * c + 1], 2);
          if (d2 < 100)
            images[c].at<uint16_t>(y, x) =
                cv::saturate_cast<uint16_t>(10000.0 * (i + 1) * std::exp(-d2 / (2 * 2.5 * 2.5)));
        }
  }
  cv::imwrite((tmp.path / "cam0.png").string(), images[0]);
  cv::imwrite((tmp.path / "cam1.png").string(), images[1]);
  const auto run = run_cli(
      "stereo rectify --rig " + rig.string() + " " + (tmp.path / "cam0.png").string() + " " +
      (tmp.path / "cam1.png").string() + " --out " + (tmp.path / "rectified").string() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const auto out = nlohmann::json::parse(run.out);
  const double focal_px = out["focal_px"].get<double>();
  const double baseline_m = out["baseline_m"].get<double>();
  cv::Mat rectified[2];
  for (int c = 0; c < 2; ++c) {
    rectified[c] = cv::imread(out["files"][c].get<std::string>(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(rectified[c].type(), CV_16UC1);
  }
  // Each blob's centroid (weighted by its values over its connected pixels above 2000 DN),
  // the blob told by its peak: 10000 (i + 1) DN less what the resampling spreads.
  auto centroid = [](const cv::Mat& m, size_t i) {
    cv::Mat labels;
    const int n = cv::connectedComponents(m > 2000, labels, 8, CV_32S);
    std::vector<double> sx(n), sy(n), sw(n), peak(n);
    for (int y = 0; y < m.rows; ++y)
      for (int x = 0; x < m.cols; ++x) {
        const int l = labels.at<int>(y, x);
        if (l == 0) continue;
        const double v = m.at<uint16_t>(y, x);
        sx[l] += v * x;
        sy[l] += v * y;
        sw[l] += v;
        peak[l] = std::max(peak[l], v);
      }
    for (int l = 1; l < n; ++l)
      if (std::lround(peak[l] / 10000) == static_cast<long>(i + 1))
        return cv::Point2d(sx[l] / sw[l], sy[l] / sw[l]);
    ADD_FAILURE() << "no blob " << i;
    return cv::Point2d(0, 0);
  };
  for (size_t i = 0; i < kStereoPoints.size(); ++i) {
    const cv::Point2d a = centroid(rectified[0], i), b = centroid(rectified[1], i);
    const double disparity = a.x - b.x;
    // The point's depth along the rectified axis: its distance projected on that axis is
    // what f B / disparity gives; the range from camera 0 bounds it from above.
    const double z_m = focal_px * baseline_m / disparity;
    std::printf("point %zu: rows %.3f and %.3f, disparity %.2f px, depth %.4f m (range %.4f)\n", i,
                a.y, b.y, disparity, z_m, cv::norm(kStereoPoints[i]));
    EXPECT_NEAR(a.y, b.y, 0.3) << "point " << i;
    EXPECT_GT(disparity, 0);
    EXPECT_LT(z_m, cv::norm(kStereoPoints[i]) * 1.001);
    EXPECT_GT(z_m, 0.9 * kStereoPoints[i][2]);
  }
  EXPECT_EQ(out["rectification"], "LENSMODEL_PINHOLE") << "auto, for a 62-deg camera 0";
  // Lat-lon: the columns are angles, and the rule the command prints gives the range.
  const auto latlon_run =
      run_cli("stereo rectify --rig " + rig.string() + " " + (tmp.path / "cam0.png").string() +
              " " + (tmp.path / "cam1.png").string() + " --out " + (tmp.path / "latlon").string() +
              " --rectification latlon --json");
  ASSERT_EQ(latlon_run.exit_code, 0) << latlon_run.err << latlon_run.out;
  const auto latlon = nlohmann::json::parse(latlon_run.out);
  EXPECT_EQ(latlon["rectification"], "LENSMODEL_LATLON");
  const double cx = latlon["principal_point_px"][0].get<double>();
  const double f = latlon["focal_px"].get<double>();
  for (int c = 0; c < 2; ++c)
    rectified[c] = cv::imread(latlon["files"][c].get<std::string>(), cv::IMREAD_UNCHANGED);
  for (size_t i = 0; i < kStereoPoints.size(); ++i) {
    const cv::Point2d a = centroid(rectified[0], i), b = centroid(rectified[1], i);
    const double az0 = (a.x - cx) / f, az1 = (b.x - cx) / f;
    const double range_m = baseline_m * std::cos(az1) / std::sin(az0 - az1);
    std::printf("lat-lon, point %zu: rows %.3f and %.3f, range %.4f m (truth %.4f)\n", i, a.y, b.y,
                range_m, cv::norm(kStereoPoints[i]));
    EXPECT_NEAR(a.y, b.y, 0.3) << "point " << i;
    EXPECT_NEAR(range_m / cv::norm(kStereoPoints[i]), 1.0, 0.01) << "point " << i;
  }
  const auto mismatched = run_cli(
      "stereo rectify --rig " + rig.string() + " " + (tmp.path / "cam1.png").string() + " " +
      (tmp.path / "cam0.png").string() + " --out " + (tmp.path / "again").string() + " --json");
  EXPECT_EQ(mismatched.exit_code, 2);
  EXPECT_NE(mismatched.out.find("imager_mismatch"), std::string::npos) << mismatched.out;
}

}  // namespace rig_cli_test
}  // namespace
}  // namespace camlab::calib
