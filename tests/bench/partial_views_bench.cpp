// Partial views at the imager's edges, rendered (docs/calibration.md, "Partial views at the
// imager's edges"; docs/BENCHMARKS.md): one plan of board poses whose boards run off the
// frame (tests/unit/calib/border_views.h: most aimed at points `--inset-px` inside the
// imager's border, the middle of the three marker squares at the aim, so a marker
// board's markers stay in view), and its whole-board twin (each board turned about the camera's
// centre until its outline is on the imager). Both are rendered by the virtual camera for a ChArUco
// board and for a chessboard with OpenCV's markers (11 x 8 squares of 60 mm, the example boards),
// detected with `--detector charuco` and `--detector markers` respectively, and calibrated
// (OPENCV8) the same way (calib/calibrate.h). Per case: views found, partial views, corners, border
// coverage (the report's), and the projection error against the truth's lens at the imager's four
// corners and along its border (unprojected through the truth, projected through the fit), and over
// its central 80% (rotation fitted). Never passes or fails.
//
//   partial_views_bench [--views 40] [--border-views 28] [--inset-px 130] [--seed 7]
//                       [--write-scenes PREFIX]   (also writes the four scenes as JSON)
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "border_views.h"
#include "calib/calibrate.h"
#include "calib/corners/marker_chessboard_corners.h"
#include "mock_device/render/renderer.h"

namespace fs = std::filesystem;
using namespace camlab;

namespace {

nlohmann::json board_target(bool charuco, const std::vector<std::array<double, 6>>& poses) {
  nlohmann::json t = {{"name", "board"},           {"square_m", 0.06},
                      {"margin_squares", 1.0},     {"dark_reflectance", 0.05},
                      {"light_reflectance", 0.85}, {"poses", poses}};
  if (charuco) {
    t["type"] = "charuco";
    t["squares"] = {11, 8};
    t["marker_m"] = 0.045;
    t["dictionary"] = "DICT_4X4_50";
  } else {
    t["type"] = "chessboard";
    t["inner_corners"] = {10, 7};
    t["markers"] = true;
  }
  return t;
}

struct Case {
  int images = 0, views = 0, partial = 0, corners = 0;
  double border_coverage = 0, central_rms_px = 0;
  calib::testing::BorderError error;
  std::string failure;
};

Case run_case(const mock::CameraSpec& camera, bool charuco,
              const std::vector<std::array<double, 6>>& poses, const fs::path& dir,
              calib::LensModel* truth) {
  Case c;
  nlohmann::json scene_json = {{"illuminance_lux", 800},
                               {"background_reflectance", 0.3},
                               {"targets", {board_target(charuco, poses)}}};
  auto scene = mock::parse_scene_spec(scene_json);
  if (!scene) return {.failure = scene.error().message};
  auto r = mock::Renderer::create(camera, std::move(*scene));
  if (!r) return {.failure = r.error().message};
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (int v = 0; v < r->scene().view_count; ++v) {
    mock::RenderOptions options;
    options.frame_number = static_cast<uint64_t>(v);
    auto frame = r->render(r->default_settings(), v, options);
    if (!frame) return {.failure = frame.error().message};
    char name[32];
    std::snprintf(name, sizeof name, "view_%02d.png", v);
    cv::imwrite((dir / name).string(), frame->image);
    if (v == 0) {
      truth->lensmodel = frame->truth["lensmodel"];
      truth->intrinsics = frame->truth["intrinsics"].get<std::vector<double>>();
      truth->width_px = frame->truth["imagersize"][0];
      truth->height_px = frame->truth["imagersize"][1];
    }
  }
  calib::CalibrateOptions o;
  o.images_dir = dir;
  o.board = {10, 7, 0.06};
  o.model = "LENSMODEL_OPENCV8";
  o.detector = charuco ? "charuco" : "markers";
  if (charuco) {
    o.charuco_marker_m = 0.045;
    o.charuco_dictionary = "DICT_4X4_50";
  }
  auto run = calib::calibrate(o);
  fs::remove_all(dir);
  if (!run) return {.failure = run.error().message};
  c.images = run->images;
  c.views = static_cast<int>(run->data.views.size());
  for (const auto& v : run->data.views) {
    c.corners += v.present_count();
    c.partial += v.present_count() < static_cast<int>(v.corners.size());
  }
  c.border_coverage = run->report.edge_coverage;
  c.error = calib::testing::border_error(*truth, run->report.solution.model);
  if (auto d = calib::projection_difference(*truth, run->report.solution.model, 0.8); d.ok())
    c.central_rms_px = d->rms_px;
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  calib::testing::BorderPlan plan;
  std::string scenes_prefix;  // --write-scenes P: P_{charuco,markers}_{cut,whole}.json
  plan.views = 40;
  plan.border_views = 28;
  plan.inset_px = 130;
  plan.distance_min_m = 0.55;
  plan.distance_max_m = 0.9;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--views")) plan.views = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--border-views")) plan.border_views = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--inset-px")) plan.inset_px = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--seed")) plan.seed = static_cast<uint32_t>(std::atoi(argv[i + 1]));
    if (!std::strcmp(argv[i], "--write-scenes")) scenes_prefix = argv[i + 1];
  }
  auto camera = mock::load_camera_spec(fs::path(CAMLAB_SOURCE_DIR) /
                                       "mock_device/examples/camera_wide_1280x800.json");
  if (!camera) {
    std::fprintf(stderr, "%s\n", camera.error().message.c_str());
    return 2;
  }
  const calib::BoardSpec board{10, 7, 0.06};
  const auto [a, b] = calib::marker_square(board.cols, board.rows);
  // The middle of the three marker squares' bounding box (squares a .. a + 1 across,
  // b - 1 .. b down): inner corner (a, b - 1).
  plan.aim_board_m = {{a * board.spacing_m, (b - 1) * board.spacing_m}};
  const calib::LensModel plan_lens = calib::testing::wide_opencv8_truth();
  const auto cut = calib::testing::border_plan_poses(plan_lens, board, plan);
  std::vector<std::array<double, 6>> whole;
  for (const auto& rt : cut) whole.push_back(calib::testing::whole_twin(plan_lens, board, rt));
  if (!scenes_prefix.empty()) {
    for (bool charuco : {true, false})
      for (int set = 0; set < 2; ++set) {
        const std::string path = scenes_prefix + (charuco ? "_charuco" : "_markers") +
                                 (set == 0 ? "_cut" : "_whole") + ".json";
        const nlohmann::json scene = {
            {"name",
             std::string(charuco ? "ChArUco board" : "Chessboard with OpenCV's markers") +
                 ", 11x8 squares of 60 mm: " + std::to_string(cut.size()) +
                 (set == 0 ? " views, most cut by the frame's edges (partial_views_bench)"
                           : " views, the cut ones' whole-board twins (partial_views_bench)")},
            {"illuminance_lux", 800},
            {"background_reflectance", 0.3},
            {"targets", {board_target(charuco, set == 0 ? cut : whole)}}};
        FILE* f = std::fopen(path.c_str(), "w");
        if (!f) return 2;
        std::fprintf(f, "%s\n", scene.dump(2).c_str());
        std::fclose(f);
      }
  }
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_partial_views_" + std::to_string(getpid()));
  std::printf(
      "%zu poses (%d aimed %.0f px inside the border), 11x8-square boards of 60 mm, "
      "OPENCV8 on the wide 1280x800 lens\n",
      cut.size(), plan.border_views, plan.inset_px);
  std::printf("%-8s %-6s %6s %8s %8s %9s %17s %17s %9s\n", "board", "poses", "views", "partial",
              "corners", "border", "corners RMS/max", "border RMS/max", "centre80");
  for (bool charuco : {true, false})
    for (int set = 0; set < 2; ++set) {
      calib::LensModel truth;
      const Case c = run_case(*camera, charuco, set == 0 ? cut : whole, dir, &truth);
      if (!c.failure.empty()) {
        std::printf("%-8s %-6s failed: %s\n", charuco ? "charuco" : "markers",
                    set == 0 ? "cut" : "whole", c.failure.c_str());
        continue;
      }
      std::printf("%-8s %-6s %3d/%-3d %7d %8d %8.0f%% %8.3f/%-8.3f %8.3f/%-8.3f %9.3f\n",
                  charuco ? "charuco" : "markers", set == 0 ? "cut" : "whole", c.views, c.images,
                  c.partial, c.corners, 100 * c.border_coverage, c.error.corners_rms_px,
                  c.error.corners_max_px, c.error.border_rms_px, c.error.border_max_px,
                  c.central_rms_px);
    }
  return 0;
}
