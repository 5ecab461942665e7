// The ChArUco detector (calib/corners/charuco_corners.h) on the virtual camera's example
// set (mock_device/examples/scene_charuco_calibration.json: 40 views of an 11x8-square
// board on the wide OPENCV8 lens, 103 deg across, 14 of them cut by the frame's edges),
// against the renderer's corner truth, which tests/unit/mock_device/charuco_render_test.cpp
// checks against a projection written out with mrcal; corners.vnl with the missing
// corners of partial views; and the calibration they make against the truth's lens.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/calibrate.h"
#include "calib/corners/charuco_corners.h"
#include "calib/corners/corners_vnl.h"
#include "calib/mrcal_api.h"
#include "mock_device/render/renderer.h"

namespace camlab::calib {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace charuco_corners_test {

namespace fs = std::filesystem;
const fs::path kExamples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
constexpr int kCols = 10, kRows = 7;  // inner corners
constexpr double kBorderPx = 50;

CharucoBoardSpec example_board() { return {11, 8, 0.06, 0.045, "DICT_4X4_50"}; }

struct View {
  cv::Mat image;
  nlohmann::json corners_px;  // by id; null off the imager
  nlohmann::json truth;       // the frame's whole truth
};

class CharucoCorners : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto camera = mock::load_camera_spec(kExamples / "camera_wide_1280x800.json");
    auto scene = mock::load_scene_spec(kExamples / "scene_charuco_calibration.json");
    ASSERT_TRUE(camera.ok() && scene.ok());
    auto r = mock::Renderer::create(std::move(*camera), std::move(*scene));
    ASSERT_TRUE(r.ok()) << r.error().message;
    views_ = new std::vector<View>();
    for (int v = 0; v < r->scene().view_count; ++v) {
      mock::RenderOptions options;
      options.frame_number = static_cast<uint64_t>(v);
      auto frame = r->render(r->default_settings(), v, options);
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      views_->push_back({frame->image, frame->truth["targets"][0]["corners_px"], frame->truth});
    }
  }
  static void TearDownTestSuite() { delete views_; }
  static std::vector<View>* views_;
};
std::vector<View>* CharucoCorners::views_ = nullptr;

bool near_border(double x, double y) {
  return x < kBorderPx || y < kBorderPx || x > 1279 - kBorderPx || y > 799 - kBorderPx;
}

TEST_F(CharucoCorners, RefinedCornersAreWithinFiveHundredthsOfAPixelRmsToTheBorder) {
  double sum_sq = 0, border_sq = 0, worst = 0, homography_sq = 0;
  int n = 0, border_n = 0, truth_visible = 0, truth_border = 0;
  for (const View& v : *views_) {
    for (const auto& t : v.corners_px)
      if (!t.is_null()) {
        ++truth_visible;
        truth_border += near_border(t[0], t[1]) ? 1 : 0;
      }
    auto d = detect_charuco(v.image, example_board());
    ASSERT_TRUE(d.ok()) << d.error().message;
    for (const CharucoCornerStages& c : d->corners) {
      if (!c.saddle_px) continue;
      const auto& t = v.corners_px[static_cast<size_t>(c.id)];
      ASSERT_FALSE(t.is_null()) << "corner " << c.id << " is off the imager in the truth";
      const cv::Point2d truth(t[0].get<double>(), t[1].get<double>());
      const double e = cv::norm(*c.saddle_px - truth);
      ASSERT_LT(e, 1.0) << "corner " << c.id << ": a wrong id or a wrong junction";
      sum_sq += e * e;
      homography_sq += cv::norm(c.homography_px - truth) * cv::norm(c.homography_px - truth);
      worst = std::max(worst, e);
      ++n;
      if (near_border(truth.x, truth.y)) {
        border_sq += e * e;
        ++border_n;
      }
    }
  }
  const double rms = std::sqrt(sum_sq / n), border_rms = std::sqrt(border_sq / border_n);
  const double homography_rms = std::sqrt(homography_sq / n);
  std::printf(
      "%d of %d corners (%d of %d within %g px of the border): RMS %.4f px, border %.4f, "
      "max %.3f; the homographies %.3f px RMS\n",
      n, truth_visible, border_n, truth_border, kBorderPx, rms, border_rms, worst, homography_rms);
  RecordProperty("corner_rms_px", std::to_string(rms));
  RecordProperty("border_corner_rms_px", std::to_string(border_rms));
  EXPECT_LT(rms, 0.05);
  EXPECT_LT(border_rms, 0.05);
  EXPECT_LT(worst, 0.3);
  // Most corners, and most of those near the border, are kept.
  EXPECT_GT(n, 0.9 * truth_visible);
  EXPECT_GT(border_n, 0.6 * truth_border);
  // The refinement is what makes them right: the homographies are bent by the distortion.
  EXPECT_GT(homography_rms, 5 * rms);
}

TEST_F(CharucoCorners, EveryIdIsTheTruthsNearestCorner) {
  int checked = 0;
  for (const View& v : *views_) {
    auto found = find_charuco_corners(v.image, example_board());
    if (!found.ok()) continue;
    ASSERT_EQ(found->ids.size(), found->corners_px.size());
    EXPECT_EQ(found->cols, kCols);
    EXPECT_EQ(found->rows, kRows);
    for (size_t k = 0; k < found->ids.size(); ++k) {
      if (k > 0) {
        EXPECT_LT(found->ids[k - 1], found->ids[k]) << "ids ascending, each once";
      }
      size_t nearest = 0;
      double best = 1e300;
      for (size_t i = 0; i < v.corners_px.size(); ++i) {
        if (v.corners_px[i].is_null()) continue;
        const double e = std::hypot(found->corners_px[k].x - v.corners_px[i][0].get<double>(),
                                    found->corners_px[k].y - v.corners_px[i][1].get<double>());
        if (e < best) best = e, nearest = i;
      }
      EXPECT_EQ(static_cast<int>(nearest), found->ids[k]);
      ++checked;
    }
  }
  EXPECT_GT(checked, 2000);
}

TEST_F(CharucoCorners, APartialBoardKeepsItsVisibleCornersWithTheirIds) {
  // View 27: the board's corner in the frame's corner, 21 of its 70 corners on the imager.
  const View& v = (*views_)[27];
  std::set<int> visible;
  for (size_t i = 0; i < v.corners_px.size(); ++i)
    if (!v.corners_px[i].is_null()) visible.insert(static_cast<int>(i));
  ASSERT_LT(visible.size(), 40u);
  auto found = find_charuco_corners(v.image, example_board());
  ASSERT_TRUE(found.ok()) << found.error().message;
  EXPECT_GE(found->ids.size(), visible.size() - 4);
  for (size_t k = 0; k < found->ids.size(); ++k) {
    const int id = found->ids[k];
    ASSERT_TRUE(visible.count(id)) << "id " << id << " is off the imager";
    const auto& t = v.corners_px[static_cast<size_t>(id)];
    EXPECT_LT(std::hypot(found->corners_px[k].x - t[0].get<double>(),
                         found->corners_px[k].y - t[1].get<double>()),
              0.2)
        << "id " << id;
  }
}

TEST_F(CharucoCorners, PartialViewsGoToCornersVnlWithTheirMissingCornersAsMissing) {
  std::vector<BoardView> views;
  for (int index : {27, 30, 34}) {
    auto found = find_charuco_corners((*views_)[static_cast<size_t>(index)].image, example_board());
    ASSERT_TRUE(found.ok());
    BoardView view;
    view.name = "frame_" + std::to_string(index) + ".png";
    view.corners.assign(kCols * kRows, CornerObservation{});
    for (size_t k = 0; k < found->ids.size(); ++k)
      view.corners[static_cast<size_t>(found->ids[k])] = {found->corners_px[k].x,
                                                          found->corners_px[k].y, 1.0, true};
    ASSERT_LT(view.present_count(), kCols * kRows);
    views.push_back(view);
  }
  const std::string text = to_corners_vnl(views);
  auto back = parse_corners_vnl(text, BoardSpec{kCols, kRows, 0.06});
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->size(), views.size());
  int missing = 0;
  for (size_t v = 0; v < views.size(); ++v)
    for (int k = 0; k < kCols * kRows; ++k) {
      const CornerObservation& a = views[v].corners[static_cast<size_t>(k)];
      const CornerObservation& b = (*back)[v].corners[static_cast<size_t>(k)];
      ASSERT_EQ(a.present, b.present) << "view " << v << " corner " << k;
      if (!a.present) {
        ++missing;
        continue;
      }
      EXPECT_EQ(a.x_px, b.x_px);
      EXPECT_EQ(a.y_px, b.y_px);
    }
  EXPECT_GT(missing, 60);
  // mrcal reads the same file: a missing corner is weight -1 in its observations.
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "Debian's python3 (with mrcal) is absent";
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_charuco_vnl_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "corners.vnl") << text;
  std::ofstream(dir / "read.py")
      << "import sys, json, mrcal\n"
      << "obs, _, files = mrcal.compute_chessboard_corners(" << kCols << ", " << kRows
      << ", corners_cache_vnl=sys.argv[1])\n"
      << "print(json.dumps([[[float(x) for x in p] for p in o.reshape(-1, 3)] for o in obs]))\n";
  const std::string command =
      "cd " + dir.string() + " && /usr/bin/python3 read.py corners.vnl 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  ASSERT_EQ(pclose(pipe), 0) << output;
  fs::remove_all(dir);
  const auto observations = nlohmann::json::parse(output.substr(output.find('[')));
  ASSERT_EQ(observations.size(), views.size());
  for (size_t v = 0; v < views.size(); ++v)
    for (int k = 0; k < kCols * kRows; ++k) {
      const CornerObservation& a = views[v].corners[static_cast<size_t>(k)];
      const auto& o = observations[v][static_cast<size_t>(k)];
      if (!a.present) {
        EXPECT_LT(o[2].get<double>(), 0) << "mrcal must see corner " << k << " as missing";
        continue;
      }
      EXPECT_NEAR(o[0].get<double>(), a.x_px, 1e-9);
      EXPECT_NEAR(o[1].get<double>(), a.y_px, 1e-9);
      EXPECT_EQ(o[2].get<double>(), 1.0);
    }
}

// calibrate() as `camlab calibrate --images DIR --detector charuco` runs it, on the
// example set saved as 16-bit PNG: partial views enter the solve with their missing
// corners, and the lens comes out as the truth's, compared by projection (each truth
// pixel unprojected through the truth's lens, projected through the solved one).
TEST_F(CharucoCorners, CalibrationFromTheViewsIsTheTruthsLens) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_charuco_cal_" + std::to_string(getpid()));
  fs::create_directories(dir);
  for (size_t k = 0; k < views_->size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "view_%02zu.png", k);
    ASSERT_TRUE(cv::imwrite((dir / name).string(), (*views_)[k].image));
  }
  CalibrateOptions o;
  o.images_dir = dir;
  o.board = {kCols, kRows, 0.06};
  o.detector = "charuco";
  o.charuco_marker_m = 0.045;
  o.charuco_dictionary = "DICT_4X4_50";
  o.model = "LENSMODEL_OPENCV8";
  o.detect_threads = 2;
  o.out_corners_vnl = dir / "corners.vnl";
  auto run = calibrate(o);
  ASSERT_TRUE(run.ok()) << run.error().message;
  const auto& detector = run->report_json["detector"];
  EXPECT_EQ(detector["requested"], "charuco");
  EXPECT_EQ(detector["views"]["charuco"], run->data.views.size());
  EXPECT_GE(detector["charuco"]["partial_views"].get<int>(), 12);
  EXPECT_GE(run->data.views.size(), 38u);
  // The solve used every view, the partial ones with their missing corners.
  EXPECT_EQ(run->report.solution.views_used.size(), run->data.views.size());
  // corners.vnl holds every view's 70 rows, the corners not found as "- - -".
  auto vnl = read_corners_vnl(dir / "corners.vnl", o.board);
  ASSERT_TRUE(vnl.ok()) << vnl.error().message;
  ASSERT_EQ(vnl->size(), run->data.views.size());
  int missing = 0;
  for (const BoardView& v : *vnl) missing += kCols * kRows - v.present_count();
  EXPECT_GT(missing, 400);
  fs::remove_all(dir);

  const auto& truth = (*views_)[1].truth;
  const std::vector<double> truth_intrinsics = truth["intrinsics"];
  const auto& model = run->report.solution.model;
  mrcal_lensmodel_t truth_lens, fitted_lens;
  ASSERT_TRUE(
      mrcal_lensmodel_from_name(&truth_lens, truth["lensmodel"].get<std::string>().c_str()));
  ASSERT_TRUE(mrcal_lensmodel_from_name(&fitted_lens, model.lensmodel.c_str()));
  double sum_sq = 0, worst = 0;
  int n = 0;
  for (int y = 0; y <= 20; ++y)
    for (int x = 0; x <= 32; ++x) {
      const mrcal_point2_t q = {.x = x * 1279.0 / 32, .y = y * 799.0 / 20};
      mrcal_point3_t v;
      mrcal_point2_t back;
      ASSERT_TRUE(mrcal_unproject(&v, &q, 1, &truth_lens, truth_intrinsics.data()));
      ASSERT_TRUE(
          mrcal_project(&back, nullptr, nullptr, &v, 1, &fitted_lens, model.intrinsics.data()));
      const double e = std::hypot(back.x - q.x, back.y - q.y);
      sum_sq += e * e;
      worst = std::max(worst, e);
      ++n;
    }
  std::printf("solved lens against the truth: %.4f px RMS over the imager, max %.3f px\n",
              std::sqrt(sum_sq / n), worst);
  EXPECT_LT(std::sqrt(sum_sq / n), 0.1);
  EXPECT_LT(worst, 0.5);
}

TEST(CharucoBoard, BadBoardsAndImagesAreRefusedSayingWhy) {
  const cv::Mat image(100, 100, CV_8UC1, cv::Scalar(128));
  CharucoBoardSpec board = example_board();
  board.marker_m = 0.06;
  auto d = detect_charuco(image, board);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().code, ErrorCode::kOutOfRange);
  EXPECT_NE(d.error().message.find("smaller than the square"), std::string::npos);
  board = example_board();
  board.dictionary = "DICT_9X9_1";
  EXPECT_EQ(detect_charuco(image, board).error().code, ErrorCode::kInvalidArgument);
  board = example_board();
  board.squares_cols = 12, board.squares_rows = 9;  // 54 light squares, 50 markers
  d = detect_charuco(image, board);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().message.find("needs 54 markers; DICT_4X4_50 has 50"), std::string::npos)
      << d.error().message;
  EXPECT_EQ(detect_charuco(cv::Mat(100, 100, CV_8UC3), example_board()).error().code,
            ErrorCode::kBadImage);
  EXPECT_EQ(detect_charuco(cv::Mat(), example_board()).error().code, ErrorCode::kBadImage);
  // No board in the image: no error from the stages, board_not_found from the finder.
  auto empty = detect_charuco(image, example_board());
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ(empty->markers, 0);
  EXPECT_TRUE(empty->corners.empty());
  auto none = find_charuco_corners(image, example_board());
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::kBoardNotFound);
}

}  // namespace charuco_corners_test
}  // namespace
}  // namespace camlab::calib
