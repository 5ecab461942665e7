// `camlab calibrate`: parses arguments, runs calib::calibrate() (calib/calibrate.h: corners
// from images, a capture folder or corners.vnl -> staged mrcal solve or `--model auto`
// selection -> report), writes the outputs and prints the report (text, or JSON).
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/calibrate.h"
#include "calib/calibration_request.h"
#include "calib/guided_session.h"
#include "calib/report.h"
#include "calib/rig/rig_calibrate.h"
#include "calib/view_suggestion.h"
#include "command_errors.h"
#include "commands.h"

namespace camlab::cli {

namespace {

struct CalibrateArgs {
  // One each, or with --rig one a camera.
  std::vector<std::string> images_dirs, job_dirs, corners_paths, imagers;
  bool rig = false;
  std::string images_dir, job_dir, corners_path, imager;  // the one of each without --rig
  std::string drift_from;
  std::string board, model = "auto", detector = "auto", sensor, out, report_path, yaml_path,
                     write_corners, plots_dir, dictionary;
  double spacing_m = 0, pixel_um = 0, focal_guess_px = 0, marker_m = 0, range_m = 0;
  bool json = false, quiet = false, no_board_warp = false, no_repeatability = false;
  // The guided calibration (calib/view_suggestion.h, calib/guided_session.h).
  bool suggest = false, watch = false;
  double target_uncertainty_px = 0, watch_timeout_s = 60, watch_poll_s = 0.5,
         suggest_distance_m = 0;
};

std::atomic<bool> g_interrupted{false};

extern "C" void on_interrupt(int) { g_interrupted = true; }

std::string coverage_line(const calib::UncertaintyCoverage& c) {
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "worst projection uncertainty %.3f px at (%.0f, %.0f) px, at %.2f m (%dx%d grid)",
                c.worst_of_grid_px, c.worst_x_px, c.worst_y_px, c.distance_m, c.cols, c.rows);
  return buf;
}

// `--watch`: calibrates the folder as images arrive until the target, Ctrl-C, or
// --watch-timeout-s without a new image; then writes the outputs as a single run does.
void run_watch(const CalibrateArgs& a, const calib::CalibrateOptions& o,
               const calib::SuggestionOptions& so, const CommandErrors& errors) {
  auto session = calib::FolderSession::open(o, so);
  if (!session) errors.fail(session.error());
  struct sigaction action {};
  action.sa_handler = on_interrupt;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  using Clock = std::chrono::steady_clock;
  auto last_new = Clock::now();
  std::string reason;
  for (;;) {
    auto poll = session->poll();
    if (!poll) errors.fail(poll.error());
    if (poll->new_images > 0) last_new = Clock::now();
    for (const auto& s : poll->skipped)
      std::fprintf(stderr, "camlab calibrate: skipped %s\n", s.c_str());
    if (poll->new_images > 0) {
      if (a.json) {
        nlohmann::json j = {{"event", "round"},
                            {"images", session->images()},
                            {"views", session->data().views.size()},
                            {"new_images", poll->new_images},
                            {"new_views", poll->new_views},
                            {"solved", poll->solved}};
        if (!poll->solve_error.empty()) j["solve_error"] = poll->solve_error;
        if (poll->coverage) j["coverage"] = calib::to_json(*poll->coverage);
        if (poll->suggestion) j["suggestion"] = calib::to_json(*poll->suggestion);
        if (!poll->suggestion_error.empty()) j["suggestion_error"] = poll->suggestion_error;
        if (!poll->skipped.empty()) j["skipped"] = poll->skipped;
        std::cout << j.dump() << std::endl;
      } else {
        std::cout << session->images() << " images, " << session->data().views.size() << " views: "
                  << (poll->coverage ? coverage_line(*poll->coverage)
                                     : "no solution yet (" + poll->solve_error + ")")
                  << "\n";
        if (poll->suggestion) std::cout << "  " << poll->suggestion->description << "\n";
        if (!poll->suggestion_error.empty())
          std::cout << "  no suggestion: " << poll->suggestion_error << "\n";
        std::cout << std::flush;
      }
    }
    if (a.target_uncertainty_px > 0 && poll->coverage &&
        poll->coverage->worst_of_grid_px < a.target_uncertainty_px) {
      reason = "target";
      break;
    }
    const auto wait = std::chrono::duration<double>(a.watch_poll_s);
    const auto until = Clock::now() + std::chrono::duration_cast<Clock::duration>(wait);
    while (!g_interrupted && Clock::now() < until) usleep(20000);
    if (g_interrupted) {
      reason = "interrupted";
      break;
    }
    if (std::chrono::duration<double>(Clock::now() - last_new).count() > a.watch_timeout_s) {
      reason = "timeout";
      break;
    }
  }
  signal(SIGINT, SIG_DFL);
  signal(SIGTERM, SIG_DFL);
  if (!a.quiet) std::fprintf(stderr, "camlab calibrate: watch ended (%s)\n", reason.c_str());
  auto run = session->run();
  if (!run) errors.fail(run.error());
  auto report = calib::write_calibration_outputs(&*run, o);
  if (!report) errors.fail(report.error());
  if (a.json) {
    std::cout << nlohmann::json{{"event", "done"}, {"reason", reason}, {"report", *report}}.dump()
              << std::endl;
  } else {
    std::cout << "watch ended: " << reason << "\n" << calib::to_text(run->report);
  }
}

// "WxH" in decimal digits, each read as a 64-bit number: one past int's range is for the
// caller to refuse as out of range, never wrapped (sscanf's %d reads 4294967310 as 14).
// "saddle 10, opencv_classic 3": the detectors that found boards, with their counts.
std::string counts_text(const nlohmann::json& by_detector) {
  std::string out;
  for (const auto& [name, n] : by_detector.items())
    if (n.is_number_integer() && n.get<int>() > 0)
      out += (out.empty() ? "" : ", ") + name + " " + std::to_string(n.get<int>());
  return out.empty() ? "none" : out;
}

// The images without a board and why, at most 10 lines (the report has them all).
void print_misses(const std::vector<calib::ImageDetection>& detections) {
  constexpr int kMaxLines = 10;
  int shown = 0, missed = 0;
  for (const auto& d : detections) {
    if (!d.detector.empty()) continue;
    if (++missed > kMaxLines) continue;
    ++shown;
    std::fprintf(stderr, "  no board in %s [%s]: %s\n", d.image.c_str(), d.why_not.c_str(),
                 d.detail.c_str());
  }
  if (missed > shown)
    std::fprintf(stderr,
                 "  ... and %d more images without the board (the report's "
                 "\"detections\" lists every image)\n",
                 missed - shown);
}

bool parse_wxh(const std::string& s, long long* w, long long* h) {
  const char* const end = s.data() + s.size();
  auto [after_w, ew] = std::from_chars(s.data(), end, *w);
  if (ew != std::errc() || after_w == end || *after_w != 'x') return false;
  auto [after_h, eh] = std::from_chars(after_w + 1, end, *h);
  return eh == std::errc() && after_h == end && *w > 0 && *h > 0;
}

// The board's inner corners, or the imager's size, from "WxH" into ints: a number past
// int's range is out of range (check_calibration_request names the limits of the rest).
void read_wxh(const CommandErrors& errors, const std::string& text, const std::string& what, int* w,
              int* h) {
  long long w64 = 0, h64 = 0;
  if (!parse_wxh(text, &w64, &h64))
    errors.fail("invalid_argument", what + " in decimal digits, e.g. 14x10");
  if (w64 > INT32_MAX || h64 > INT32_MAX)
    errors.fail("out_of_range", what + ": " + text + " is past any board or imager");
  *w = static_cast<int>(w64);
  *h = static_cast<int>(h64);
}

// The board and its detector, as every camera of a run sees them.
calib::CalibrateOptions board_options(const CalibrateArgs& a, const CommandErrors& errors) {
  calib::CalibrateOptions o;
  read_wxh(errors, a.board, "--board must be COLSxROWS inner corners", &o.board.cols,
           &o.board.rows);
  o.board.spacing_m = a.spacing_m;
  o.detector = a.detector;
  o.charuco_marker_m = a.marker_m;
  o.charuco_dictionary = a.dictionary;
  return o;
}

void run_calibrate_rig(const CalibrateArgs& a);

void run_calibrate(CalibrateArgs a) {
  const CommandErrors errors("camlab calibrate", a.json);
  if (a.rig) {
    run_calibrate_rig(a);
    return;
  }
  for (const auto* many : {&a.images_dirs, &a.job_dirs, &a.corners_paths, &a.imagers})
    if (many->size() > 1)
      errors.fail("invalid_argument",
                  "--images, --job, --corners and --imager are given once for one camera; "
                  "several, one a camera, with --rig");
  auto first = [](const std::vector<std::string>& v) { return v.empty() ? "" : v[0]; };
  a.images_dir = first(a.images_dirs);
  a.job_dir = first(a.job_dirs);
  a.corners_path = first(a.corners_paths);
  a.imager = first(a.imagers);
  calib::CalibrateOptions o = board_options(a, errors);
  o.images_dir = a.images_dir;
  o.job_dir = a.job_dir;
  o.corners_vnl = a.corners_path;
  if (!a.imager.empty())
    read_wxh(errors, a.imager, "--imager must be WxH pixels", &o.imager_width_px,
             &o.imager_height_px);
  o.model = a.model;
  o.pixel_pitch_um = a.pixel_um;
  o.sensor = a.sensor;
  o.focal_guess_px = a.focal_guess_px;
  o.board_warp = !a.no_board_warp;
  o.repeatability = !a.no_repeatability;
  // Checked here, before any image is read, by the rules camlabd applies to the same
  // request (calib/calibration_request.h): the board, the detector and its markers, the
  // model, the sensor, the source. Where a rule is about flags, the message names them
  // (the code is the rule's own).
  if (!a.corners_path.empty() && a.imager.empty())
    errors.fail("invalid_argument",
                "--corners needs --imager WxH (corners.vnl does not record the imager size)");
  if (a.detector == "charuco" && (a.marker_m == 0 || a.dictionary.empty()))
    errors.fail("invalid_argument",
                "--detector charuco needs the board's markers: --marker-m and --dictionary");
  if (a.detector != "charuco" && (a.marker_m != 0 || !a.dictionary.empty()))
    errors.fail("invalid_argument",
                "--marker-m and --dictionary describe a ChArUco board: add --detector charuco");
  if (Status s = calib::check_calibration_request(o); !s) errors.fail(s.error());
  o.out_cameramodel = a.out;
  o.out_report_json = a.report_path;
  o.out_opencv_yaml = a.yaml_path;
  o.out_corners_vnl = a.write_corners;
  o.plots_dir = a.plots_dir;
  const bool tty = isatty(STDERR_FILENO) && !a.quiet;
  if (tty)
    o.progress = [](size_t done, size_t total, int boards) {
      const int width = 30, bar = static_cast<int>(width * done / std::max<size_t>(1, total));
      std::fprintf(stderr, "\rcamlab calibrate: corners [%s%s] %zu/%zu images, %d boards%s",
                   std::string(bar, '#').c_str(), std::string(width - bar, '.').c_str(), done,
                   total, boards, done == total ? "\n" : "");
    };

  calib::SuggestionOptions so;
  so.distance_m = a.suggest_distance_m;
  // A ChArUco board is found from part of it; a chessboard only whole.
  so.whole_board_required = !calib::detector_keeps_partial_boards(a.detector);
  if (!(a.suggest_distance_m >= 0) || !std::isfinite(a.suggest_distance_m))
    errors.fail("invalid_argument", "--suggest-distance-m must be >= 0 (0: the working distance)");
  if (!(a.target_uncertainty_px >= 0) || !std::isfinite(a.target_uncertainty_px))
    errors.fail("invalid_argument", "--target-uncertainty-px must be >= 0 px (0: no target)");
  if (!(a.watch_timeout_s > 0 && a.watch_timeout_s <= 86400))
    errors.fail("invalid_argument", "--watch-timeout-s must be in (0, 86400] s");
  if (!(a.watch_poll_s >= 0.05 && a.watch_poll_s <= 60))
    errors.fail("invalid_argument", "--watch-poll-s must be in [0.05, 60] s");
  if (a.watch) {
    if (a.images_dir.empty() || !a.job_dir.empty() || !a.corners_path.empty())
      errors.fail("invalid_argument", "--watch needs --images DIR (and no other source)");
    run_watch(a, o, so, errors);
    return;
  }

  auto run = calib::calibrate(o);
  if (!run) errors.fail(run.error());
  if (!a.quiet && run->images > 0) {
    const nlohmann::json by = run->report_json.value("detector", nlohmann::json::object())
                                  .value("views", nlohmann::json::object());
    const nlohmann::json charuco = run->report_json["detector"].value("charuco", nlohmann::json());
    const nlohmann::json markers = run->report_json["detector"].value("markers", nlohmann::json());
    if (!markers.is_null())
      std::fprintf(stderr,
                   "camlab calibrate: found the marker chessboard in %zu of %d images (%d "
                   "corners; %d partial views)\n",
                   run->data.views.size(), run->images, markers.value("corners", 0),
                   markers.value("partial_views", 0));
    else if (!charuco.is_null())
      std::fprintf(stderr,
                   "camlab calibrate: found ChArUco corners in %zu of %d images (%d corners; %d "
                   "partial views)\n",
                   run->data.views.size(), run->images, charuco.value("corners", 0),
                   charuco.value("partial_views", 0));
    else
      std::fprintf(stderr, "camlab calibrate: found the board in %zu of %d images (%s)\n",
                   run->data.views.size(), run->images, counts_text(by).c_str());
    print_misses(run->detections);
  }
  auto report = calib::write_calibration_outputs(&*run, o);
  if (!report) errors.fail(report.error());
  // --suggest: the current worst uncertainty and where to put the board next. The
  // calibration stands without it: an error here is reported, not fatal.
  std::optional<calib::UncertaintyCoverage> coverage;
  std::optional<calib::ViewSuggestion> suggestion;
  std::optional<Error> suggest_error;
  if (a.suggest) {
    const calib::Solution& solution = run->report.solution;
    auto c = calib::uncertainty_coverage(solution, so);
    auto next = calib::suggest_next_view(run->data, &solution, so);
    if (c) coverage = *c;
    if (next)
      suggestion = *next;
    else
      suggest_error = next.error();
  }
  if (a.json) {
    if (coverage) (*report)["coverage"] = calib::to_json(*coverage);
    if (suggestion) (*report)["suggestion"] = calib::to_json(*suggestion);
    if (suggest_error)
      (*report)["suggestion"] = {
          {"error", {{"code", name_of(suggest_error->code)}, {"message", suggest_error->message}}}};
    std::cout << report->dump(2) << "\n";
  } else {
    std::cout << calib::to_text(run->report);
    if (coverage) std::cout << "Guided calibration: " << coverage_line(*coverage) << "\n";
    if (suggestion) std::cout << suggestion->description << "\n";
    if (suggest_error) std::cout << "No suggestion: " << suggest_error->text() << "\n";
  }
}

// --rig: one source a camera, the joint solve (calib/rig/rig_calibrate.h).
void run_calibrate_rig(const CalibrateArgs& a) {
  const CommandErrors errors("camlab calibrate --rig", a.json);
  const size_t kinds = !a.images_dirs.empty() + !a.job_dirs.empty() + !a.corners_paths.empty();
  if (kinds != 1)
    errors.fail("invalid_argument",
                "--rig takes one kind of source, one a camera: --images DIR, --job DIR or "
                "--corners FILE, repeated in camera order");
  const std::vector<std::string>& sources =
      !a.images_dirs.empty() ? a.images_dirs : (!a.job_dirs.empty() ? a.job_dirs : a.corners_paths);
  if (!a.corners_paths.empty() && a.imagers.size() != 1 && a.imagers.size() != sources.size())
    errors.fail("invalid_argument",
                "--rig --corners needs --imager WxH, once for all cameras or once a camera "
                "(corners.vnl does not record the imager size)");
  if (a.watch || a.suggest)
    errors.fail("invalid_argument", "--watch and --suggest are for one camera, not --rig");
  calib::RigCalibrateOptions rig;
  rig.model = a.model;
  rig.board_warp = !a.no_board_warp;
  rig.out_dir = a.out;
  if (!(a.range_m >= 0 && a.range_m <= 1e5))
    errors.fail("out_of_range", "--range-m must be in [0, 100000] m (0: none)");
  rig.range_m = a.range_m;
  rig.drift_from = a.drift_from;
  for (size_t c = 0; c < sources.size(); ++c) {
    calib::CalibrateOptions o = board_options(a, errors);
    if (!a.images_dirs.empty()) o.images_dir = sources[c];
    if (!a.job_dirs.empty()) o.job_dir = sources[c];
    if (!a.corners_paths.empty()) o.corners_vnl = sources[c];
    if (!a.imagers.empty())
      read_wxh(errors, a.imagers[a.imagers.size() == 1 ? 0 : c], "--imager must be WxH pixels",
               &o.imager_width_px, &o.imager_height_px);
    o.model = a.model;
    if (Status s = calib::check_calibration_request(o); !s)
      errors.fail(s.error().with_context("camera " + std::to_string(c) + ": "));
    rig.cameras.push_back(std::move(o));
  }
  auto run = calib::calibrate_rig(rig);
  if (!run) errors.fail(run.error());
  if (a.json)
    std::cout << run->report.dump(2) << "\n";
  else
    std::cout << calib::rig_report_text(*run);
}

}  // namespace

void register_calibrate_command(CLI::App& app) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Calibrate a camera's intrinsics with mrcal from chessboard or ChArUco views");
  cmd->add_option("--images", args->images_dirs,
                  "Folder of board images, or a pattern of file names in one folder "
                  "('DIR/left*.jpg'; quote it) (with --rig: one a camera, in camera order; "
                  "views matched by file name, or by the part a pattern's * matches)");
  cmd->add_option("--job", args->job_dirs,
                  "camlab capture folder of board frames (with --rig: one a camera)");
  cmd->add_option("--corners", args->corners_paths,
                  "mrcal corners.vnl (# filename x y level) (with --rig: one a camera)");
  cmd->add_flag("--rig", args->rig,
                "Calibrate a rig of 2 to 8 cameras jointly: one --images, --job or --corners "
                "a camera (camera 0 first, the reference), views matched by file name; --out "
                "is a folder that gets camera-N.cameramodel (mrcal's extrinsics, relative to "
                "camera 0) and rig.json (each camera's pose with its 1-sigma rotation in deg "
                "and translation in mm). --model auto selects each camera's model on its own "
                "views and each camera keeps it (a fisheye beside pinhole lenses included); "
                "--model NAME gives every camera NAME");
  cmd->add_option("--board", args->board, "Inner corners COLSxROWS, e.g. 14x10")->required();
  cmd->add_option("--spacing-m", args->spacing_m, "Corner spacing in metres")->required();
  cmd->add_option("--model", args->model, "auto (default) or a mrcal LENSMODEL_... name");
  cmd->add_option(
      "--detector", args->detector,
      "Corner detector for --images/--job: auto (default), saddle, opencv or mrgingham for a "
      "chessboard, charuco for a ChArUco board. saddle: saddle points at reduced resolution, "
      "a grid grown from them, cornerSubPix at full resolution (any board, a few ms an "
      "image); auto: a cascade, each stage where the ones before found no board: saddle, "
      "mrgingham (mrcal's detector, N x N boards only), OpenCV's classic findChessboardCorners, "
      "then findChessboardCornersSB, so it finds every board OpenCV's detectors find; a grid "
      "that is part of a bigger board is refused, and each image without a board is reported "
      "with why; opencv: findChessboardCornersSB's exhaustive search + cornerSubPix (any "
      "board, 0.2-0.9 s an image); markers: a chessboard with OpenCV's three circle "
      "markers near its middle (findChessboardCornersSB's CALIB_CB_MARKER layout): the "
      "saddle grid, whole or cut by the frame, named by the markers, partial boards kept "
      "(a view must show the three marker squares); charuco: OpenCV's ArUco markers name the "
      "corners, "
      "each refined as the image's saddle point, partial boards kept (needs --marker-m and "
      "--dictionary; --board counts inner corners, squares - 1, and --spacing-m is the "
      "square)");
  cmd->add_option("--marker-m", args->marker_m,
                  "ChArUco: a marker's side in metres, its black border included");
  cmd->add_option("--dictionary", args->dictionary,
                  "ChArUco: OpenCV's ArUco dictionary, e.g. DICT_4X4_50, DICT_5X5_100");
  cmd->add_option("--range-m", args->range_m,
                  "--rig: the 1-sigma (mm) the calibration leaves in the range of a point this "
                  "far (m) along camera 0's axis, triangulated with each other camera");
  cmd->add_option("--drift-from", args->drift_from,
                  "--rig: an earlier rig.json of this rig; says per camera whether it moved "
                  "beyond what the two calibrations' noise explains (chi-square of 6 degrees "
                  "of freedom above 22.46)");
  cmd->add_option("--imager", args->imagers,
                  "Imager size WxH (px); default: from the images (with --rig and --corners: "
                  "one a camera, or one for all)");
  auto pixel = cmd->add_option("--pixel-um", args->pixel_um, "Pixel pitch in micrometres");
  cmd->add_option("--sensor", args->sensor, "Sensor format (full-frame, aps-c, 1/2.3in, ...)")
      ->excludes(pixel);
  cmd->add_option("--focal-guess-px", args->focal_guess_px,
                  "Optional focal length guess (px); searched around, never trusted");
  cmd->add_option("--out", args->out, "Output .cameramodel (with --rig: a folder)")->required();
  cmd->add_option("--report", args->report_path, "Write the JSON report here");
  cmd->add_option("--opencv-yaml", args->yaml_path,
                  "Write OpenCV YAML (camera_matrix, distortion_coefficients)");
  cmd->add_option("--write-corners", args->write_corners, "Write the corners used as corners.vnl");
  cmd->add_option(
      "--plots", args->plots_dir,
      "Write PNG plots here: residuals, residual histogram, coverage, uncertainty, distortion");
  cmd->add_flag("--no-board-warp", args->no_board_warp,
                "Skip the board-warp stage (for a board known to be flat to a few um)");
  cmd->add_flag("--no-repeatability", args->no_repeatability,
                "Skip the repeatability check (odd and even views solved apart and compared; "
                "each view predicted by the model solved without it, at most 24)");
  cmd->add_flag("--suggest", args->suggest,
                "After the calibration, print the worst projection uncertainty over the imager "
                "and the next view that most reduces it (with --json: \"coverage\" and "
                "\"suggestion\" objects)");
  cmd->add_option("--suggest-distance-m", args->suggest_distance_m,
                  "Distance (m) at which the uncertainty is taken and the board suggested; "
                  "default 0: the working distance (median distance of the boards)");
  cmd->add_flag("--watch", args->watch,
                "Keep calibrating the --images folder as new images arrive: detect only the "
                "new ones, re-solve warm-started, print the next suggestion each time (with "
                "--json one JSON object per line); ends at --target-uncertainty-px, on Ctrl-C, or "
                "after --watch-timeout-s without a new image, then writes the outputs. With "
                "--model auto or a splined model the loop solves LENSMODEL_OPENCV8 and the end "
                "runs the requested model on every view");
  cmd->add_option("--target-uncertainty-px", args->target_uncertainty_px,
                  "--watch: stop once the worst projection uncertainty is below this (px); "
                  "default 0: no target");
  cmd->add_option("--watch-timeout-s", args->watch_timeout_s,
                  "--watch: stop after this long without a new image (s, default 60)");
  cmd->add_option("--watch-poll-s", args->watch_poll_s,
                  "--watch: how often the folder is listed (s, default 0.5)");
  cmd->add_flag("--json", args->json, "Print the report as JSON");
  cmd->add_flag("--quiet", args->quiet, "No progress output");
  cmd->callback([args] { run_calibrate(*args); });
}

}  // namespace camlab::cli
