// The marker chessboard detector (calib/corners/marker_chessboard_corners.h) on the
// virtual camera's example set (mock_device/examples/scene_marker_chessboard_calibration.json:
// 40 views of a 10x7-corner chessboard with OpenCV's three circle markers on the wide
// OPENCV8 lens, most of them cut by the frame's edges), against the renderer's corner
// truth: every corner named must be the truth's corner of that id (within 0.25 px);
// nearly every view must be found. Then `--detector markers` end to end on the same
// frames: the partial views cover the imager's border and the lens comes out right at its
// corners. And the naming on its own: the same lattice with its axes turned or swapped
// names the same corners, and a board without markers is no board.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "border_views.h"
#include "calib/calibrate.h"
#include "calib/corners/marker_chessboard_corners.h"
#include "calib/corners/saddle_corners.h"
#include "mock_device/render/renderer.h"

namespace camlab::calib {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace marker_chessboard_test {

namespace fs = std::filesystem;
const fs::path kExamples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
constexpr int kCols = 10, kRows = 7;

struct View {
  cv::Mat image;
  nlohmann::json truth;  // the frame's whole truth
};

class MarkerChessboard : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto camera = mock::load_camera_spec(kExamples / "camera_wide_1280x800.json");
    auto scene = mock::load_scene_spec(kExamples / "scene_marker_chessboard_calibration.json");
    ASSERT_TRUE(camera.ok() && scene.ok());
    auto r = mock::Renderer::create(std::move(*camera), std::move(*scene));
    ASSERT_TRUE(r.ok()) << r.error().message;
    views_ = new std::vector<View>();
    for (int v = 0; v < r->scene().view_count; ++v) {
      mock::RenderOptions options;
      options.frame_number = static_cast<uint64_t>(v);
      auto frame = r->render(r->default_settings(), v, options);
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      views_->push_back({frame->image, frame->truth});
    }
  }
  static void TearDownTestSuite() { delete views_; }
  static std::vector<View>* views_;
};
std::vector<View>* MarkerChessboard::views_ = nullptr;

TEST_F(MarkerChessboard, EveryNamedCornerIsTheTruthsCornerOfItsId) {
  int cut = 0, cut_found = 0, whole = 0, whole_found = 0, corners = 0;
  double sum_sq = 0;
  for (size_t v = 0; v < views_->size(); ++v) {
    const nlohmann::json& target = (*views_)[v].truth["targets"][0];
    int on_imager = 0;
    for (const auto& p : target["corners_px"]) on_imager += !p.is_null();
    const bool is_whole = on_imager == kCols * kRows;
    (is_whole ? whole : cut) += 1;
    auto found = find_marker_chessboard((*views_)[v].image, kCols, kRows);
    if (!found) continue;
    (is_whole ? whole_found : cut_found) += 1;
    for (size_t k = 0; k < found->ids.size(); ++k) {
      // The projection of the corner of that id, on the imager or not.
      const nlohmann::json& t = target["corners_projected_px"][static_cast<size_t>(found->ids[k])];
      ASSERT_FALSE(t.is_null()) << "view " << v << ": id " << found->ids[k] << " is behind";
      const double e = std::hypot(found->corners_px[k].x - t[0].get<double>(),
                                  found->corners_px[k].y - t[1].get<double>());
      EXPECT_LT(e, 0.25) << "view " << v << " id " << found->ids[k];
      sum_sq += e * e;
      ++corners;
    }
  }
  const double rms = std::sqrt(sum_sq / std::max(1, corners));
  std::printf("whole boards found %d of %d, cut boards %d of %d; %d corners, %.3f px RMS\n",
              whole_found, whole, cut_found, cut, corners, rms);
  EXPECT_EQ(whole_found, whole);
  EXPECT_GE(cut, 20);  // the set is what it says
  EXPECT_GE(cut_found, cut * 2 / 3);
  EXPECT_LT(rms, 0.05);
}

TEST_F(MarkerChessboard, TurnedOrSwappedLatticeAxesNameTheSameCorners) {
  // The first view of a whole board.
  size_t first_whole = 0;
  for (; first_whole < views_->size(); ++first_whole) {
    int on_imager = 0;
    for (const auto& p : (*views_)[first_whole].truth["targets"][0]["corners_px"])
      on_imager += !p.is_null();
    if (on_imager == kCols * kRows) break;
  }
  ASSERT_LT(first_whole, views_->size());
  const View& v = (*views_)[first_whole];
  auto lattice = find_saddle_lattice(v.image, std::max(kCols, kRows) + 1, 9);
  ASSERT_TRUE(lattice.ok()) << lattice.error().message;
  auto reference = name_by_markers(v.image, lattice->ij, lattice->corners_px, kCols, kRows);
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  // The lattice's indices under a quarter turn, a half turn and a swap of its axes (a
  // mirror of the index grid: the image is the same, so the board is not mirrored).
  for (int g = 1; g < 4; ++g) {
    std::vector<cv::Point2i> ij;
    for (const cv::Point2i& c : lattice->ij)
      ij.push_back(g == 1   ? cv::Point2i(-c.y, c.x)
                   : g == 2 ? cv::Point2i(-c.x, -c.y)
                            : cv::Point2i(c.y, c.x));
    auto named = name_by_markers(v.image, ij, lattice->corners_px, kCols, kRows);
    ASSERT_TRUE(named.ok()) << named.error().message;
    // The same ids at the same pixels (in another order: the grid is walked differently).
    std::map<int, cv::Point2d> a, b;
    for (size_t k = 0; k < reference->ids.size(); ++k)
      a[reference->ids[k]] = reference->corners_px[k];
    for (size_t k = 0; k < named->ids.size(); ++k) b[named->ids[k]] = named->corners_px[k];
    ASSERT_EQ(a.size(), b.size()) << "symmetry " << g;
    for (const auto& [id, p] : a) {
      ASSERT_EQ(b.count(id), 1u) << "symmetry " << g << ": id " << id;
      EXPECT_LT(cv::norm(b[id] - p), 1e-9) << "symmetry " << g << ": id " << id;
    }
  }
}

TEST(MarkerChessboardErrors, ABoardWithoutMarkersIsNoBoard) {
  auto camera = mock::load_camera_spec(kExamples / "camera_wide_1280x800.json");
  auto scene_json =
      nlohmann::json::parse(std::ifstream(kExamples / "scene_marker_chessboard_calibration.json"));
  scene_json["targets"][0]["markers"] = false;
  auto scene = mock::parse_scene_spec(scene_json);
  ASSERT_TRUE(camera.ok() && scene.ok());
  auto r = mock::Renderer::create(std::move(*camera), std::move(*scene));
  ASSERT_TRUE(r.ok());
  auto frame = r->render(r->default_settings(), 0, mock::RenderOptions{});
  ASSERT_TRUE(frame.ok());
  auto found = find_marker_chessboard(frame->image, kCols, kRows);
  ASSERT_FALSE(found.ok());
  EXPECT_EQ(found.error().code, "board_not_found");
  EXPECT_NE(found.error().message.find("marker"), std::string::npos) << found.error().message;
}

TEST_F(MarkerChessboard, CalibrateWithPartialViewsCoversTheBorderAndGetsTheCornersRight) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_marker_cal_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (size_t v = 0; v < views_->size(); ++v) {
    char name[32];
    std::snprintf(name, sizeof name, "view_%02zu.png", v);
    ASSERT_TRUE(cv::imwrite((dir / name).string(), (*views_)[v].image));
  }
  CalibrateOptions o;
  o.images_dir = dir;
  o.board = {kCols, kRows, 0.06};
  o.model = "LENSMODEL_OPENCV8";
  o.detector = "markers";
  auto run = calibrate(o);
  fs::remove_all(dir);
  ASSERT_TRUE(run.ok()) << run.error().message;
  const nlohmann::json& d = run->report_json["detector"];
  EXPECT_EQ(d["requested"], "markers");
  EXPECT_GE(d["markers"]["partial_views"].get<int>(), 15);
  EXPECT_GE(run->report.edge_coverage, 0.9);
  const nlohmann::json& truth = (*views_)[0].truth;
  const LensModel truth_lens{truth["lensmodel"], truth["intrinsics"].get<std::vector<double>>(),
                             truth["imagersize"][0], truth["imagersize"][1]};
  const auto e = testing::border_error(truth_lens, run->report.solution.model);
  std::printf(
      "%zu views, %d partial; border coverage %.0f%%; imager corners %.3f px RMS from "
      "the truth, border %.3f px RMS\n",
      run->data.views.size(), d["markers"]["partial_views"].get<int>(),
      100 * run->report.edge_coverage, e.corners_rms_px, e.border_rms_px);
  EXPECT_LT(e.corners_rms_px, 0.5);
  EXPECT_LT(e.border_rms_px, 0.2);
}

}  // namespace marker_chessboard_test
}  // namespace
}  // namespace camlab::calib
