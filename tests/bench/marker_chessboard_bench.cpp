// Partial chessboard views with OpenCV 4.6's markers (docs/calibration.md, "Chessboards
// with markers"): renders the marker chessboard example set
// (mock_device/examples/scene_marker_chessboard_calibration.json) in process and, per
// view, runs (a) OpenCV 4.6's findChessboardCornersSB with CALIB_CB_LARGER |
// CALIB_CB_MARKER (found or not, and whether its grid, named by camlab's marker reading,
// is right); (b) its grid with CALIB_CB_LARGER alone, named by
// camlab's marker reading (name_by_markers, calib/corners/marker_chessboard_corners.h);
// (c) camlab's detector, find_marker_chessboard (the saddle lattice named by the same
// marker reading). (b) and (c) are checked against the renderer's truth: a view is
// "right" when every corner named lies within 0.5 px of the truth's corner of that id.
// Prints a line per view (a * after "cut": the marker squares are not all on the imager)
// and the totals; never passes or fails.
//
//   marker_chessboard_bench [--scene FILE] [--camera FILE]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include "calib/corners/image_8bit.h"
#include "calib/corners/marker_chessboard_corners.h"
#include "mock_device/render/renderer.h"

namespace fs = std::filesystem;
using namespace camlab;

namespace {

// Worst distance (px) from a named corner to the truth's corner of its id; INFINITY for
// an id behind the camera.
double worst_error(const calib::MarkerChessboardCorners& c, const nlohmann::json& projected) {
  double worst = 0;
  for (size_t k = 0; k < c.ids.size(); ++k) {
    const nlohmann::json& t = projected[static_cast<size_t>(c.ids[k])];
    if (t.is_null()) return INFINITY;
    worst = std::max(worst, std::hypot(c.corners_px[k].x - t[0].get<double>(),
                                       c.corners_px[k].y - t[1].get<double>()));
  }
  return worst;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path examples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
  fs::path scene_path = examples / "scene_marker_chessboard_calibration.json";
  fs::path camera_path = examples / "camera_wide_1280x800.json";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--scene")) scene_path = argv[i + 1];
    if (!std::strcmp(argv[i], "--camera")) camera_path = argv[i + 1];
  }
  auto camera = mock::load_camera_spec(camera_path);
  auto scene = mock::load_scene_spec(scene_path);
  if (!camera || !scene) {
    std::fprintf(stderr, "cannot load the camera or the scene\n");
    return 2;
  }
  const int cols = scene->targets[0].corners_cols, rows = scene->targets[0].corners_rows;
  auto r = mock::Renderer::create(std::move(*camera), std::move(*scene));
  if (!r) {
    std::fprintf(stderr, "%s\n", r.error().message.c_str());
    return 2;
  }
  int n[2] = {0, 0}, a_found[2] = {0, 0}, found[2][2] = {{0, 0}, {0, 0}},
      right[2][2] = {{0, 0}, {0, 0}}, corners[2][2] = {{0, 0}, {0, 0}};
  double seconds[2] = {0, 0};
  int markers_seen[2] = {0, 0}, a_right[2] = {0, 0};
  std::printf(
      "view  board  (a) LARGER|MARKER  (b) LARGER grid + camlab's markers      "
      "(c) saddle lattice + markers\n");
  for (int v = 0; v < r->scene().view_count; ++v) {
    mock::RenderOptions options;
    options.frame_number = static_cast<uint64_t>(v);
    auto frame = r->render(r->default_settings(), v, options);
    if (!frame) {
      std::fprintf(stderr, "%s\n", frame.error().message.c_str());
      return 2;
    }
    const nlohmann::json& target = frame->truth["targets"][0];
    int on_imager = 0;
    for (const auto& p : target["corners_px"]) on_imager += !p.is_null();
    const int cut = on_imager < cols * rows ? 1 : 0;
    ++n[cut];
    // Whether the three marker squares are whole on the imager: their corners, inner
    // corners (a - 1 .. a + 1, b - 2 .. b), all in the truth's corners_px.
    const auto [ma, mb] = calib::marker_square(cols, rows);
    bool markers_in_view = true;
    for (int j = mb - 2; j <= mb; ++j)
      for (int i = ma - 1; i <= ma + 1; ++i)
        if (i >= 0 && j >= 0 && i < cols && j < rows &&
            target["corners_px"][static_cast<size_t>(j * cols + i)].is_null())
          markers_in_view = false;
    markers_seen[cut] += markers_in_view;
    const cv::Mat view8 = calib::stretch_to_8bit(frame->image);
    cv::Mat grid, meta;
    const bool a_ok = cv::findChessboardCornersSB(view8, cv::Size(4, 4), grid,
                                                  cv::CALIB_CB_LARGER | cv::CALIB_CB_MARKER, meta);
    a_found[cut] += a_ok;
    // Its grid's ids: OpenCV's meta array marks the origin but its grid comes back
    // transposed or flipped from view to view, so the grid is named as (b) names its own.
    if (a_ok) {
      grid = grid.reshape(2, meta.rows * meta.cols);
      std::vector<cv::Point2i> ij;
      std::vector<cv::Point2d> px;
      for (int k = 0; k < meta.rows * meta.cols; ++k) {
        ij.emplace_back(k % meta.cols, k / meta.cols);
        px.emplace_back(grid.at<cv::Point2f>(k));
      }
      auto named = calib::name_by_markers(frame->image, ij, px, cols, rows);
      a_right[cut] += named.ok() && worst_error(*named, target["corners_projected_px"]) < 0.5;
    }
    std::string text[2];
    for (int method = 0; method < 2; ++method) {
      const auto t0 = std::chrono::steady_clock::now();
      camlab::Result<calib::MarkerChessboardCorners> c =
          camlab::make_error("board_not_found", "no grid");
      if (method == 0) {
        cv::Mat g, m;
        if (cv::findChessboardCornersSB(view8, cv::Size(4, 4), g, cv::CALIB_CB_LARGER, m)) {
          g = g.reshape(2, m.rows * m.cols);
          std::vector<cv::Point2i> ij;
          std::vector<cv::Point2d> px;
          for (int k = 0; k < m.rows * m.cols; ++k) {
            ij.emplace_back(k % m.cols, k / m.cols);
            px.emplace_back(g.at<cv::Point2f>(k));
          }
          c = calib::name_by_markers(frame->image, ij, px, cols, rows);
        }
      } else {
        c = calib::find_marker_chessboard(frame->image, cols, rows);
      }
      seconds[method] +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (c) {
        ++found[method][cut];
        const double worst = worst_error(*c, target["corners_projected_px"]);
        right[method][cut] += worst < 0.5;
        corners[method][cut] += static_cast<int>(c->ids.size());
        char line[96];
        std::snprintf(line, sizeof line, "%zu corners, worst %.2f px%s", c->ids.size(), worst,
                      worst < 0.5 ? "" : " WRONG");
        text[method] = line;
      } else {
        text[method] = "- " + c.error().message.substr(0, 30);
      }
    }
    std::printf(
        "%4d  %-5s%s %-18s %-39s %s\n", v, cut ? "cut" : "whole", markers_in_view ? "" : "*",
        a_ok ? ("grid " + std::to_string(meta.cols) + "x" + std::to_string(meta.rows)).c_str()
             : "-",
        text[0].c_str(), text[1].c_str());
  }
  for (int cut = 0; cut < 2; ++cut)
    std::printf(
        "%s boards: %d (%d with the marker squares on the imager); (a) finds %d, %d named right; "
        "(b) %d, %d with "
        "every id right (%d corners); "
        "(c) %d, %d with every id right (%d corners)\n",
        cut ? "cut" : "whole", n[cut], markers_seen[cut], a_found[cut], a_right[cut], found[0][cut],
        right[0][cut], corners[0][cut], found[1][cut], right[1][cut], corners[1][cut]);
  std::printf("time per image: (b) %.0f ms, (c) %.0f ms\n", 1e3 * seconds[0] / (n[0] + n[1]),
              1e3 * seconds[1] / (n[0] + n[1]));
  return 0;
}
