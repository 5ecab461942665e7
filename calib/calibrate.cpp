// The calibration run behind `camlab calibrate` and POST /v1/calibrations.
#include "calib/calibrate.h"

#include <fnmatch.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "base/atomic_file.h"
#include "base/cancel.h"
#include "base/format.h"
#include "calib/calibration_request.h"
#include "calib/corners/charuco_corners.h"
#include "calib/corners/chessboard_detector.h"
#include "calib/corners/corners_vnl.h"
#include "calib/corners/marker_chessboard_corners.h"
#include "calib/lens_model.h"
#include "calib/library_stderr.h"
#include "calib/model_io.h"
#include "calib/model_selection.h"
#include "calib/plots.h"
#include "calib/repeatability.h"
#include "calib/solver.h"
#include "image/capture_folder.h"
#include "image/frame_views.h"
#include "optics/optics.h"

namespace camlab::calib {

bool is_calibration_image(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" ||
         ext == ".pgm" || ext == ".bmp";
}

namespace {

namespace fs = std::filesystem;

// An image to search for the board: its name, and how to read it. Images are read on the
// detection threads: decoding a 16-bit PNG costs about as much as finding its corners.
struct ImageSource {
  std::string name;
  std::function<Result<cv::Mat>()> load;
};

// An image file as grey levels at its own depth (8 or 16 bit); colour is converted.
Result<cv::Mat> read_grey_image(const fs::path& f) {
  cv::Mat m;
  try {
    m = cv::imread(f.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    return make_error("io_error", "cannot read image '" + f.string() + "': " + e.what());
  }
  if (m.empty()) return make_error("io_error", "cannot read image '" + f.string() + "'");
  return m;
}

Result<std::vector<ImageSource>> images_dir_sources(const fs::path& source) {
  // A folder, or a pattern of file names in one folder (DIR/left*.jpg).
  const bool pattern = is_image_pattern(source);
  const fs::path dir = pattern ? source.parent_path() : source;
  const std::string name_pattern = source.filename().string();
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir.empty() ? fs::path(".") : dir, ec))
    if (is_calibration_image(e.path()) &&
        (!pattern || fnmatch(name_pattern.c_str(), e.path().filename().c_str(), 0) == 0))
      files.push_back(e.path());
  if (ec) return make_error("io_error", "cannot list '" + dir.string() + "': " + ec.message());
  std::sort(files.begin(), files.end());
  if (files.empty())
    return make_error("io_error",
                      "no images (png, jpg, tif, pgm, bmp) in '" + source.string() + "'");
  std::vector<ImageSource> out;
  for (const auto& f : files)
    out.push_back({f.filename().string(), [f] { return read_grey_image(f); }});
  return out;
}

Result<std::vector<ImageSource>> job_sources(const fs::path& dir) {
  image::CaptureFolder opened;
  CAMLAB_ASSIGN(opened, image::CaptureFolder::open(dir));
  // Shared by the loaders; reading frames from it is const.
  auto folder = std::make_shared<const image::CaptureFolder>(std::move(opened));
  std::vector<ImageSource> out;
  for (size_t i = 0; i < folder->frames().size(); ++i)
    out.push_back({folder->frames()[i].image_file, [folder, i]() -> Result<cv::Mat> {
                     // Corners are geometry: colour frames are searched in their luminance.
                     cv::Mat stored;
                     image::FrameSidecar sidecar;
                     CAMLAB_ASSIGN(sidecar, folder->load_sidecar(static_cast<int>(i)));
                     CAMLAB_ASSIGN(stored, folder->load_stored_image(static_cast<int>(i)));
                     return image::luminance_view(stored, sidecar);
                   }});
  if (out.empty())
    return make_error("io_error", "the capture folder '" + dir.string() + "' holds no frames");
  return out;
}

bool is_charuco(const CalibrateOptions& options) { return options.detector == "charuco"; }

// Error "cancelled" once options.cancel is set: checked between images and after each solve.
Status check_not_cancelled(const CalibrateOptions& options) {
  return camlab::check_not_cancelled(options.cancel, "calibration");
}

CharucoBoardSpec charuco_board(const CalibrateOptions& options) {
  return {options.board.cols + 1, options.board.rows + 1, options.board.spacing_m,
          options.charuco_marker_m, options.charuco_dictionary};
}

}  // namespace

bool is_image_pattern(const fs::path& images) {
  return images.filename().string().find_first_of("*?[") != std::string::npos;
}

bool detector_keeps_partial_boards(const std::string& detector) {
  return detector == "charuco" || detector == "markers";
}

std::optional<BoardView> detect_board_view(const cv::Mat& image, const CalibrateOptions& options,
                                           BoardMiss* miss) {
  const BoardSpec& board = options.board;
  BoardView v;
  // A named detector's own error is the reason; auto's cascade says more (BoardMiss).
  auto missed = [&](const Error& e) {
    if (miss && miss->reason.empty()) *miss = {"board_not_found", e.message};
    return std::nullopt;
  };
  if (is_charuco(options)) {
    auto c = find_charuco_corners(image, charuco_board(options));
    if (!c) return missed(c.error());
    // By id: a ChArUco id is the corner's row-major index; the corners not found stay
    // missing, as mrcal takes a partial view.
    v.corners.assign(static_cast<size_t>(board.cols * board.rows), CornerObservation{});
    for (size_t k = 0; k < c->ids.size(); ++k)
      v.corners[static_cast<size_t>(c->ids[k])] = {c->corners_px[k].x, c->corners_px[k].y, 1.0,
                                                   true};
    v.detector = "charuco";
    return v;
  }
  if (options.detector == "markers") {
    auto c = find_marker_chessboard(image, board.cols, board.rows);
    if (!c) return missed(c.error());
    // By id, as for ChArUco: the markers name the corners; those not found stay missing.
    v.corners.assign(static_cast<size_t>(board.cols * board.rows), CornerObservation{});
    for (size_t k = 0; k < c->ids.size(); ++k)
      v.corners[static_cast<size_t>(c->ids[k])] = {c->corners_px[k].x, c->corners_px[k].y, 1.0,
                                                   true};
    v.detector = "markers";
    return v;
  }
  auto c = find_chessboard(image, board.cols, board.rows, options.detector, miss);
  if (!c) return missed(c.error());
  v.detector = c->detector;
  for (size_t k = 0; k < c->corners_px.size(); ++k)
    // Weight 0: a corner the detector could not place; mrcal takes it as missing.
    v.corners.push_back({c->corners_px[k].x, c->corners_px[k].y, c->weights[k], c->weights[k] > 0});
  return v;
}

namespace {

// Reads each image and detects the board in it on up to options.detect_threads threads
// (images are independent) with options.detector; views keep the images' order and
// record which detector found them. The first unreadable image (in order) is the error,
// and so is the first whose size differs from the first image's.
Status detect(const std::vector<ImageSource>& images, const CalibrateOptions& options,
              CalibrationData* data, std::vector<ImageDetection>* detections) {
  if (Status s = check_calibration_request(options, /*need_source=*/false); !s) return s;
  struct Outcome {
    std::optional<Error> load_error;
    cv::Size size;
    std::optional<BoardView> view;
    BoardMiss miss;
  };
  std::vector<Outcome> outcomes(images.size());
  std::atomic<size_t> next{0}, done{0};
  std::atomic<int> boards{0};
  std::atomic<bool> failed{false};
  std::mutex progress_mutex;
  auto worker = [&] {
    for (size_t i; !failed && check_not_cancelled(options) && (i = next++) < images.size();) {
      Outcome& o = outcomes[i];
      auto image = images[i].load();
      if (!image) {
        o.load_error = image.error();
        failed = true;
        break;
      }
      o.size = image->size();
      o.view = detect_board_view(*image, options, &o.miss);
      if (o.view) ++boards;
      const size_t n = ++done;
      if (options.progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        options.progress(n, images.size(), boards.load());
      }
    }
  };
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const unsigned threads = std::clamp(
      options.detect_threads > 0 ? static_cast<unsigned>(options.detect_threads) : hw, 1u, 16u);
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads && t < images.size(); ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (Status s = check_not_cancelled(options); !s) return s;
  for (const auto& o : outcomes)
    if (o.load_error) return *o.load_error;
  for (size_t i = 0; i < images.size(); ++i) {
    const cv::Size size = outcomes[i].size;
    if (data->imager_width_px == 0) {
      data->imager_width_px = size.width;
      data->imager_height_px = size.height;
    } else if (size.width != data->imager_width_px || size.height != data->imager_height_px) {
      return make_error("imager_mismatch",
                        "image '" + images[i].name + "' is " + std::to_string(size.width) + "x" +
                            std::to_string(size.height) + "; the first image was " +
                            std::to_string(data->imager_width_px) + "x" +
                            std::to_string(data->imager_height_px));
    }
  }
  for (size_t i = 0; i < images.size(); ++i) {
    Outcome& o = outcomes[i];
    detections->push_back({images[i].name, o.view ? o.view->detector : "",
                           o.view ? "" : o.miss.reason, o.view ? "" : o.miss.detail});
    if (!o.view) continue;
    o.view->name = images[i].name;
    data->views.push_back(std::move(*o.view));
  }
  return {};
}

Result<std::string> model_name(const CalibrateOptions& options, const CalibrationData& data,
                               const SolveOptions& solve_options) {
  std::string name;
  CAMLAB_ASSIGN(
      name, configured_lensmodel(options.model, data.imager_width_px, data.imager_height_px, 90));
  // A bare splined model needs the field of view for its default grid: from a first
  // OPENCV8 solve.
  if (name.find("SPLINED") != std::string::npos &&
      options.model.find("fov_x_deg") == std::string::npos) {
    SolveOptions o = solve_options;
    o.lensmodel = "LENSMODEL_OPENCV8";
    o.compute_covariance = false;
    if (auto s = solve(data, o); s.ok())
      if (auto fov = field_of_view(s->model); fov.ok())
        CAMLAB_ASSIGN(name, configured_lensmodel(options.model, data.imager_width_px,
                                                 data.imager_height_px, fov->horizontal_deg));
  }
  return name;
}

// Warning "halves_disagree" when the odd and even halves' projections differ by more than
// 0.3 px and 3x what the projection uncertainty allows (the difference of two halves,
// each with sqrt(2) x the whole set's uncertainty at the centre, has twice its sigma). On
// OpenCV's sample camera B (13 views) the halves differ by 1.19 px: their board warps
// (0.11 and -0.005 mm) and focal lengths (536.0 and 539.8 px) trade; with the board
// held flat they differ by 0.57 px.
std::optional<Warning> halves_disagree(const Repeatability& r, const CalibrationReport& report) {
  if (!r.odd_even_ran || !report.uncertainty || report.uncertainty->points.empty() ||
      !report.uncertainty->points[0].at_infinity_px)
    return std::nullopt;
  const double allowed_px = 2 * *report.uncertainty->points[0].at_infinity_px;
  if (!(r.odd_even_rms_px > 0.3 && r.odd_even_rms_px > 3 * allowed_px)) return std::nullopt;
  return Warning{
      "halves_disagree",
      format_printf("odd and even views solved apart differ by %.2f px RMS over the central 80%%, "
                    "%.1fx what the projection uncertainty allows: the calibration does not "
                    "repeat. Their focal lengths are %.1f and %.1f px and their board warps %.3f "
                    "and %.3f mm: where the warp and the focal length trade, capture more views "
                    "at varied tilt (40-60 deg about both axes), or use --no-board-warp for a "
                    "board flat to a few um",
                    r.odd_even_rms_px, r.odd_even_rms_px / allowed_px, r.halves_focal_px[0],
                    r.halves_focal_px[1], 1e3 * r.halves_warp_m[0][0],
                    1e3 * r.halves_warp_m[1][0])};
}

// "10 no_corners, 3 partial_board (e.g. img7.png: the largest ...)": the reasons no board
// was found, counted, with the first image's detail.
std::string misses_summary(const std::vector<ImageDetection>& detections) {
  std::map<std::string, int> counts;
  const ImageDetection* first = nullptr;
  for (const auto& d : detections)
    if (d.detector.empty()) {
      ++counts[d.why_not.empty() ? "board_not_found" : d.why_not];
      if (!first) first = &d;
    }
  std::string out;
  for (const auto& [reason, n] : counts)
    out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + reason;
  if (first) out += " (e.g. " + first->image + ": " + first->detail + ")";
  return out;
}

// Outputs are written atomically (a reader, e.g. the daemon serving a job's files, never
// sees half a file).
Status write_text(const fs::path& path, const std::string& text) {
  return write_file_atomically(path, text);
}

}  // namespace

Result<CalibrationRun> read_board_views(const CalibrateOptions& options) {
  if (Status s = check_calibration_request(options); !s) return s.error();
  CalibrationRun run;
  CalibrationData& data = run.data;
  data.board = options.board;
  if (!options.corners_vnl.empty()) {
    CAMLAB_ASSIGN(data.views, read_corners_vnl(options.corners_vnl.string(), data.board));
  } else {
    std::vector<ImageSource> images;
    CAMLAB_ASSIGN(images, options.images_dir.empty() ? job_sources(options.job_dir)
                                                     : images_dir_sources(options.images_dir));
    run.images = static_cast<int>(images.size());
    if (Status s = detect(images, options, &data, &run.detections); !s) return s.error();
    if (data.views.empty() && is_charuco(options))
      return make_error("no_board", "no corner of the " + std::to_string(data.board.cols + 1) +
                                        "x" + std::to_string(data.board.rows + 1) + "-square " +
                                        options.charuco_dictionary +
                                        " ChArUco board found in any of the " +
                                        std::to_string(images.size()) +
                                        " images (check --board: inner corners, not squares; "
                                        "the dictionary and the marker size)");
    if (data.views.empty())
      return make_error("no_board", "no " + std::to_string(data.board.cols) + "x" +
                                        std::to_string(data.board.rows) +
                                        " inner-corner chessboard found in any of the " +
                                        std::to_string(images.size()) +
                                        " images (check --board: inner corners, "
                                        "not squares): " +
                                        misses_summary(run.detections));
  }
  if (options.imager_width_px > 0) {
    data.imager_width_px = options.imager_width_px;
    data.imager_height_px = options.imager_height_px;
  }
  return run;
}

Result<CalibrationRun> calibrate(const CalibrateOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  CalibrationRun run;
  CAMLAB_ASSIGN(run, read_board_views(options));
  CalibrationData& data = run.data;
  // Written before the solve, so the corners survive a solve that fails.
  if (!options.out_corners_vnl.empty())
    if (Status s = write_text(options.out_corners_vnl, to_corners_vnl(data.views)); !s)
      return s.error();
  double pitch_um = options.pixel_pitch_um;
  if (!options.sensor.empty()) {
    optics::SensorFormat format;
    CAMLAB_ASSIGN(format, optics::find_sensor_format(options.sensor));
    pitch_um = format.width_mm * 1000.0 / data.imager_width_px;
  } else if (pitch_um == 0 && !options.job_dir.empty()) {
    // A capture folder may know its camera's pitch (camlabd reads it the same way).
    if (auto folder = image::CaptureFolder::open(options.job_dir); folder.ok()) {
      const double recorded = image::manifest_pixel_pitch_um(*folder);
      if (recorded >= kPixelPitchMinUm && recorded <= kPixelPitchMaxUm) pitch_um = recorded;
    }
  }

  const double read_and_detect_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // From here on mrcal runs: what it prints goes to the log (library_stderr.h). Not
  // during detection, whose progress a caller may print on stderr.
  const LibraryStderrCapture quiet_mrcal;
  SolveOptions solve_options;
  solve_options.focal_guess_px = options.focal_guess_px;
  solve_options.board_warp = options.board_warp;
  solve_options.cancel = options.cancel;
  Solution solution;
  std::vector<ModelEvidence> evidence;
  std::string cross_validation;
  SplineCheck spline_check;
  if (options.model == "auto") {
    auto selected = select_model(data, solve_options, default_candidate_models());
    if (Status s = check_not_cancelled(options); !s) return s.error();
    ModelSelection sel;
    CAMLAB_ASSIGN(sel, std::move(selected));
    solution = std::move(sel.chosen);
    evidence = std::move(sel.evidence);
    cross_validation = sel.cross_validation;
    spline_check = sel.spline_check;
  } else {
    CAMLAB_ASSIGN(solve_options.lensmodel, model_name(options, data, solve_options));
    CAMLAB_ASSIGN(solution, solve(data, solve_options));
  }
  if (Status s = check_not_cancelled(options); !s) return s.error();
  run.report = make_report(data, solution, pitch_um);
  run.report.evidence = std::move(evidence);
  run.report.cross_validation = cross_validation;
  run.report.spline_check = spline_check;
  if (options.repeatability) {
    auto repeatability = measure_repeatability(data, solve_options, solution);
    if (Status s = check_not_cancelled(options); !s) return s.error();
    if (repeatability) {
      if (auto w = halves_disagree(*repeatability, run.report)) run.report.warnings.push_back(*w);
      run.report.repeatability = std::move(*repeatability);
    } else {
      run.report.repeatability_error = repeatability.error().message;
    }
  }
  run.report_json = to_json(run.report);
  run.report_json["images"] = run.images;
  // Wall time of the two parts: reading and detection (or reading corners.vnl), and the
  // solve with model selection and the report.
  run.report_json["time_s"] = {
      {"detect", read_and_detect_s},
      {"solve", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() -
                    read_and_detect_s}};
  if (run.images > 0) {
    // Boards found per detector: under "auto", each stage's count after "saddle" is the
    // images the stages before it missed.
    nlohmann::json views_by_detector = is_charuco(options) ? nlohmann::json{{"charuco", 0}}
                                       : options.detector == "markers"
                                           ? nlohmann::json{{"markers", 0}}
                                           : nlohmann::json{{"saddle", 0},
                                                            {"mrgingham", 0},
                                                            {"opencv_classic", 0},
                                                            {"opencv_sb", 0},
                                                            {"opencv", 0}};
    for (const auto& v : data.views)
      views_by_detector[v.detector] = views_by_detector.value(v.detector, 0) + 1;
    run.report_json["detector"] = {{"requested", options.detector}, {"views", views_by_detector}};
    // Every image's outcome: which detector found the board, or why none did.
    nlohmann::json per_image = nlohmann::json::array(), not_found = nlohmann::json::object();
    for (const auto& d : run.detections) {
      if (!d.detector.empty()) {
        per_image.push_back({{"image", d.image}, {"detector", d.detector}});
        continue;
      }
      per_image.push_back({{"image", d.image}, {"why_not", d.why_not}, {"detail", d.detail}});
      not_found[d.why_not] = not_found.value(d.why_not, 0) + 1;
    }
    run.report_json["detector"]["not_found"] = not_found;
    run.report_json["detections"] = per_image;
    // Partial views are the point of a ChArUco or marker board: how many, and the
    // corners found.
    int corners = 0, partial = 0;
    for (const auto& v : data.views) {
      corners += v.present_count();
      partial += v.present_count() < static_cast<int>(v.corners.size()) ? 1 : 0;
    }
    if (options.detector == "markers")
      run.report_json["detector"]["markers"] = {{"corners", corners}, {"partial_views", partial}};
    if (is_charuco(options)) {
      run.report_json["detector"]["charuco"] = {
          {"squares", {data.board.cols + 1, data.board.rows + 1}},
          {"square_m", data.board.spacing_m},
          {"marker_m", options.charuco_marker_m},
          {"dictionary", options.charuco_dictionary},
          {"corners", corners},
          {"partial_views", partial}};
    }
  }
  // With mrcal's optimization_inputs, so mrcal's uncertainty and residual tools read it.
  CAMLAB_ASSIGN(run.cameramodel_text,
                cameramodel_text_with_inputs(solution, data,
                                             "camlab calibrate: " + solution.model.lensmodel));
  if (has_opencv_equivalent(solution.model))
    if (auto yaml = opencv_yaml_text(solution.model); yaml.ok())
      run.opencv_yaml_text = std::move(*yaml);
  return run;
}

Result<std::optional<BoardView>> detect_image_view(const fs::path& image,
                                                   const CalibrateOptions& options, int* width_px,
                                                   int* height_px) {
  if (Status s = check_calibration_request(options, /*need_source=*/false); !s) return s.error();
  cv::Mat m;
  CAMLAB_ASSIGN(m, read_grey_image(image));
  *width_px = m.cols;
  *height_px = m.rows;
  auto view = detect_board_view(m, options);
  if (view) view->name = image.filename().string();
  return view;
}

Result<nlohmann::json> calibrate_folder(const CalibrateOptions& options) {
  CalibrationRun run;
  CAMLAB_ASSIGN(run, calibrate(options));
  return write_calibration_outputs(&run, options);
}

Result<nlohmann::json> write_calibration_outputs(CalibrationRun* run_ptr,
                                                 const CalibrateOptions& options) {
  CalibrationRun& run = *run_ptr;
  nlohmann::json& j = run.report_json;
  nlohmann::json files = nlohmann::json::object();
  auto write = [&](const fs::path& path, const std::string& text, const char* key) -> Status {
    if (path.empty()) return {};
    if (Status s = write_text(path, text); !s) return s;
    files[key] = path.string();
    return {};
  };
  if (Status s = write(options.out_cameramodel, run.cameramodel_text, "cameramodel"); !s)
    return s.error();
  if (!options.out_opencv_yaml.empty()) {
    if (!run.opencv_yaml_text)
      return make_error(
          "unsupported",
          run.report.solution.model.lensmodel +
              " has no OpenCV equivalent; OpenCV YAML needs PINHOLE or OPENCV4/5/8/12");
    if (Status s = write(options.out_opencv_yaml, *run.opencv_yaml_text, "opencv_yaml"); !s)
      return s.error();
  }
  if (!options.out_corners_vnl.empty()) files["corners_vnl"] = options.out_corners_vnl.string();
  if (!options.plots_dir.empty()) {
    auto plots = write_calibration_plots(options.plots_dir, run.data, run.report);
    // No gnuplot to draw them: the model and the report stand, and say so.
    if (!plots && plots.error().code != ErrorCode::kPlotterFailed) return plots.error();
    if (plots) {
      for (const auto& p : plots->written) files["plots"].push_back(p.string());
      if (!plots->skipped.empty()) j["plots_skipped"] = plots->skipped;
    } else {
      j["plots_skipped"] = nlohmann::json::array({plots.error().message});
    }
  }
  if (!options.out_report_json.empty()) files["report"] = options.out_report_json.string();
  j["files"] = files;
  if (Status s = write(options.out_report_json, j.dump(2) + "\n", "report"); !s) return s.error();
  return j;
}

}  // namespace camlab::calib
