// `camlab calibrate`: chessboard corners (images, a capture folder, or corners.vnl) ->
// staged mrcal solve (one model, or `--model auto` selection) -> .cameramodel, OpenCV YAML,
// report (text, or JSON with --json / --report).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <optional>
#include <thread>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/chessboard_corners.h"
#include "calib/corners_vnl.h"
#include "calib/lens_model.h"
#include "calib/model_io.h"
#include "calib/model_selection.h"
#include "calib/report.h"
#include "calib/solver.h"
#include "commands.h"
#include "image/capture_folder.h"
#include "optics/optics.h"

namespace camlab::cli {

namespace {

namespace fs = std::filesystem;

struct CalibrateArgs {
  std::string images_dir, job_dir, corners_path;
  std::string board = "", imager, model = "auto", sensor, out, report_path, yaml_path,
              write_corners;
  double spacing_m = 0, pixel_um = 0, focal_guess_px = 0;
  bool json = false, quiet = false, no_board_warp = false;
};

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "camlab calibrate: %s\n", message.c_str());
  throw CLI::RuntimeError(2);
}

bool parse_wxh(const std::string& s, int* w, int* h) {
  char extra = 0;
  return std::sscanf(s.c_str(), "%dx%d%c", w, h, &extra) == 2 && *w > 0 && *h > 0;
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out.good()) fail("cannot write '" + path + "'");
}

// Detects the board in each image on all cores (images are independent), with a
// progress line on a terminal. Views keep the images' order.
void detect(const std::vector<std::pair<std::string, cv::Mat>>& images, calib::CalibrationData* data,
            bool quiet) {
  for (const auto& [name, image] : images) {
    if (data->imager_width_px == 0) {
      data->imager_width_px = image.cols;
      data->imager_height_px = image.rows;
    } else if (image.cols != data->imager_width_px || image.rows != data->imager_height_px) {
      fail("image '" + name + "' is " + std::to_string(image.cols) + "x" +
           std::to_string(image.rows) + "; the first image was " +
           std::to_string(data->imager_width_px) + "x" + std::to_string(data->imager_height_px));
    }
  }
  const bool tty = isatty(STDERR_FILENO) && !quiet;
  std::vector<std::optional<calib::ChessboardCorners>> found(images.size());
  std::atomic<size_t> next{0}, done{0};
  std::atomic<int> boards{0};
  std::mutex print_mutex;
  auto worker = [&] {
    for (size_t i; (i = next++) < images.size();) {
      auto corners = calib::find_chessboard_corners(images[i].second, data->board.cols, data->board.rows);
      if (corners) {
        found[i] = std::move(*corners);
        ++boards;
      }
      const size_t n = ++done;
      if (tty) {
        std::lock_guard<std::mutex> lock(print_mutex);
        const int width = 30, bar = static_cast<int>(width * n / images.size());
        std::fprintf(stderr, "\rcamlab calibrate: corners [%s%s] %zu/%zu images, %d boards",
                     std::string(bar, '#').c_str(), std::string(width - bar, '.').c_str(), n,
                     images.size(), boards.load());
      }
    }
  };
  const unsigned threads = std::clamp(std::thread::hardware_concurrency(), 1u, 16u);
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (tty) std::fprintf(stderr, "\n");
  for (size_t i = 0; i < images.size(); ++i) {
    if (!found[i]) continue;
    calib::BoardView v;
    v.name = images[i].first;
    for (const auto& p : found[i]->corners_px) v.corners.push_back({p.x, p.y, 1.0, true});
    data->views.push_back(std::move(v));
  }
  if (!quiet)
    std::fprintf(stderr, "camlab calibrate: found the board in %d of %zu images\n", boards.load(),
                 images.size());
}

std::vector<std::pair<std::string, cv::Mat>> load_images_dir(const std::string& dir) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" ||
        ext == ".pgm" || ext == ".bmp")
      files.push_back(e.path());
  }
  if (ec) fail("cannot list '" + dir + "': " + ec.message());
  std::sort(files.begin(), files.end());
  if (files.empty()) fail("no images (png, jpg, tif, pgm, bmp) in '" + dir + "'");
  std::vector<std::pair<std::string, cv::Mat>> out;
  for (const auto& f : files) {
    cv::Mat m = cv::imread(f.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
    if (m.empty()) fail("cannot read image '" + f.string() + "'");
    out.emplace_back(f.filename().string(), m);
  }
  return out;
}

std::vector<std::pair<std::string, cv::Mat>> load_job(const std::string& dir) {
  auto folder = image::CaptureFolder::open(dir);
  if (!folder) fail(folder.error().message);
  std::vector<std::pair<std::string, cv::Mat>> out;
  for (size_t i = 0; i < folder->frames().size(); ++i) {
    auto m = folder->load_image(static_cast<int>(i));
    if (!m) fail(m.error().message);
    out.emplace_back(folder->frames()[i].image_file, *m);
  }
  if (out.empty()) fail("the capture folder '" + dir + "' holds no frames");
  return out;
}

void run_calibrate(const CalibrateArgs& a) {
  const int sources = !a.images_dir.empty() + !a.job_dir.empty() + !a.corners_path.empty();
  if (sources != 1) fail("give exactly one of --images DIR, --job DIR, --corners FILE.vnl");
  calib::CalibrationData data;
  if (!parse_wxh(a.board, &data.board.cols, &data.board.rows) || data.board.cols < 2 ||
      data.board.rows < 2)
    fail("--board must be COLSxROWS inner corners, e.g. 14x10");
  if (!(a.spacing_m > 0) || a.spacing_m > 10) fail("--spacing-m must be in (0, 10] metres");
  data.board.spacing_m = a.spacing_m;
  int iw = 0, ih = 0;
  if (!a.imager.empty() && !parse_wxh(a.imager, &iw, &ih)) fail("--imager must be WxH pixels");
  if (a.pixel_um < 0 || a.pixel_um > 100) fail("--pixel-um must be in (0, 100]");

  if (!a.corners_path.empty()) {
    auto views = calib::read_corners_vnl(a.corners_path, data.board);
    if (!views) fail(views.error().message);
    data.views = std::move(*views);
    if (iw == 0) fail("--corners needs --imager WxH (corners.vnl does not record the imager size)");
  } else {
    detect(a.images_dir.empty() ? load_job(a.job_dir) : load_images_dir(a.images_dir), &data,
           a.quiet);
  }
  if (iw > 0) {
    data.imager_width_px = iw;
    data.imager_height_px = ih;
  }
  if (!a.write_corners.empty()) write_file(a.write_corners, calib::to_corners_vnl(data.views));

  double pixel_um = a.pixel_um;
  if (!a.sensor.empty()) {
    auto format = optics::find_sensor_format(a.sensor);
    if (!format) fail(format.error().message);
    pixel_um = format->width_mm * 1000.0 / data.imager_width_px;
  }

  calib::SolveOptions options;
  options.focal_guess_px = a.focal_guess_px;
  options.board_warp = !a.no_board_warp;
  calib::Solution solution;
  std::vector<calib::ModelEvidence> evidence;
  if (a.model == "auto") {
    auto sel = calib::select_model(data, options, calib::default_candidate_models());
    if (!sel) fail(sel.error().message);
    solution = std::move(sel->chosen);
    evidence = std::move(sel->evidence);
  } else {
    // A first solve gives the FOV a splined model's default grid needs.
    auto name = calib::configured_lensmodel(a.model, data.imager_width_px, data.imager_height_px, 90);
    if (!name) fail(name.error().message);
    if (name->find("SPLINED") != std::string::npos && a.model.find("fov_x_deg") == std::string::npos) {
      calib::SolveOptions o = options;
      o.lensmodel = "LENSMODEL_OPENCV8";
      if (auto s = calib::solve(data, o); s.ok())
        if (auto fov = calib::field_of_view(s->model); fov.ok())
          name = calib::configured_lensmodel(a.model, data.imager_width_px, data.imager_height_px,
                                             fov->horizontal_deg);
      if (!name) fail(name.error().message);
    }
    options.lensmodel = *name;
    auto s = calib::solve(data, options);
    if (!s) fail(s.error().message);
    solution = std::move(*s);
  }
  calib::CalibrationReport report = calib::make_report(data, solution, pixel_um);
  report.evidence = std::move(evidence);

  write_file(a.out, calib::cameramodel_text(solution.model, "camlab calibrate: " + solution.model.lensmodel));
  if (!a.yaml_path.empty()) {
    auto yaml = calib::opencv_yaml_text(solution.model);
    if (!yaml) fail(yaml.error().message);
    write_file(a.yaml_path, *yaml);
  }
  const nlohmann::json j = calib::to_json(report);
  if (!a.report_path.empty()) write_file(a.report_path, j.dump(2) + "\n");
  if (a.json)
    std::cout << j.dump(2) << "\n";
  else
    std::cout << calib::to_text(report);
}

}  // namespace

void register_calibrate_command(CLI::App& app) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand("calibrate", "Calibrate a camera's intrinsics with mrcal from chessboard views");
  cmd->add_option("--images", args->images_dir, "Folder of chessboard images");
  cmd->add_option("--job", args->job_dir, "camlab capture folder of chessboard frames");
  cmd->add_option("--corners", args->corners_path, "mrcal corners.vnl (# filename x y level)");
  cmd->add_option("--board", args->board, "Inner corners COLSxROWS, e.g. 14x10")->required();
  cmd->add_option("--spacing-m", args->spacing_m, "Corner spacing in metres")->required();
  cmd->add_option("--model", args->model, "auto (default) or a mrcal LENSMODEL_... name");
  cmd->add_option("--imager", args->imager, "Imager size WxH (px); default: from the images");
  auto pixel = cmd->add_option("--pixel-um", args->pixel_um, "Pixel pitch in micrometres");
  cmd->add_option("--sensor", args->sensor, "Sensor format (full-frame, aps-c, 1/2.3in, ...)")->excludes(pixel);
  cmd->add_option("--focal-guess-px", args->focal_guess_px, "Optional focal length guess (px); searched around, never trusted");
  cmd->add_option("--out", args->out, "Output .cameramodel")->required();
  cmd->add_option("--report", args->report_path, "Write the JSON report here");
  cmd->add_option("--opencv-yaml", args->yaml_path, "Write OpenCV YAML (camera_matrix, distortion_coefficients)");
  cmd->add_option("--write-corners", args->write_corners, "Write the corners used as corners.vnl");
  cmd->add_flag("--no-board-warp", args->no_board_warp,
                "Skip the board-warp stage (for a board known to be flat to a few um)");
  cmd->add_flag("--json", args->json, "Print the report as JSON");
  cmd->add_flag("--quiet", args->quiet, "No progress output");
  cmd->callback([args] { run_calibrate(*args); });
}

}  // namespace camlab::cli
