// A whole calibration run, as `camlab calibrate` and the daemon's POST /v1/calibrations
// do it: corners from a folder of images, a capture folder, or a corners.vnl file; the
// staged solve of one model or `--model auto` selection; the report; and, when paths are
// given, the output files (.cameramodel, OpenCV YAML, JSON report, corners.vnl, plots).
// The CLI only parses arguments and prints; the daemon calls the same functions.
//
// Reentrant; detection uses up to `detect_threads` threads per call.
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/corners/chessboard_detector.h"
#include "calib/report.h"

namespace camlab::calib {

struct CalibrateOptions {
  // Exactly one source.
  // png/jpg/tif/pgm/bmp, 8- or 16-bit grey or colour: a folder, or a pattern of file names
  // in one folder (DIR/left*.jpg, fnmatch's * ? [...] in the name only)
  std::filesystem::path images_dir;
  std::filesystem::path job_dir;      // a camlab capture folder (docs/capture-folder.md)
  std::filesystem::path corners_vnl;  // mrcal corners.vnl; needs imager_width/height_px
  BoardSpec board;                    // inner corners and spacing (required)
  int imager_width_px = 0, imager_height_px = 0;  // 0: from the images
  std::string model = "auto";  // "auto" or a mrcal LENSMODEL_... name (prefix optional)
  double pixel_pitch_um = 0;   // > 0: focal length in mm and 35-mm equivalent
  std::string sensor;          // a sensor format name instead of the pitch (optics)
  double focal_guess_px = 0;   // searched around, never trusted
  bool board_warp = true;
  // Odd/even and leave-one-out repeatability in the report (calib/repeatability.h): two
  // half-data solves and up to 24 leave-one-out solves, each warm-started.
  bool repeatability = true;
  int detect_threads = 0;  // 0: hardware concurrency, at most 16
  // auto | saddle | opencv | mrgingham (calib/corners/chessboard_detector.h), or charuco
  // for a ChArUco board (calib/corners/charuco_corners.h): its squares are board.cols + 1
  // by board.rows + 1 of board.spacing_m, and these two describe its markers. A view of a
  // ChArUco board keeps the corners found, the others missing (a board cut by the frame).
  // markers: a chessboard with OpenCV's three circle markers
  // (calib/corners/marker_chessboard_corners.h), whose views keep their corners the same way.
  std::string detector = "auto";
  double charuco_marker_m = 0;     // a marker's side, its black border included
  std::string charuco_dictionary;  // cv::aruco's name, e.g. DICT_4X4_50
  // Outputs written by calibrate_folder() when not empty.
  std::filesystem::path out_cameramodel, out_report_json, out_opencv_yaml, out_corners_vnl,
      plots_dir;
  // Called after each image's detection (done, total, boards found so far), from the
  // detection threads one at a time. May be empty.
  std::function<void(size_t done, size_t total, int boards)> progress;
  // Set by another thread to stop the run: no new image is read and no new solve stage
  // starts; calibrate() then returns "cancelled" (within one mrcal_optimize call, which is
  // bounded by the lens-model limits of lens_model.h). Null: runs to the end.
  const std::atomic<bool>* cancel = nullptr;
};

// One image's outcome of the board search: the detector that found the board, or why
// none did (calib/corners/chessboard_detector.h's BoardMiss reasons; "board_not_found"
// from a detector named in --detector, which does not say why).
struct ImageDetection {
  std::string image;
  std::string detector;  // empty: no board found
  std::string why_not;   // with no board: the reason, a stable key
  std::string detail;    // with no board: the reason for a person
};

struct CalibrationRun {
  CalibrationData data;                    // the corners used
  int images = 0;                          // images read (0 for corners.vnl)
  std::vector<ImageDetection> detections;  // one per image read, in the images' order
  CalibrationReport report;                // report.solution holds the model
  nlohmann::json report_json;
  std::string cameramodel_text;                 // full precision (model_io.h)
  std::optional<std::string> opencv_yaml_text;  // when the model has an OpenCV equivalent
};

// Whether a file is an image the calibration reads (png, jpg, tif, pgm, bmp, by extension).
bool is_calibration_image(const std::filesystem::path& path);

// Whether `images` (CalibrateOptions::images_dir) is a pattern of file names, not a folder.
bool is_image_pattern(const std::filesystem::path& images);

// Whether `detector` keeps boards cut by the frame (charuco, markers): the guided
// calibration may then suggest poses that show part of the board.
bool detector_keeps_partial_boards(const std::string& detector);

// One image's board as a view with options.detector (checked by the caller, as the
// request validation of calibration_request.h does):
// row-major corners in mrcal's order, a ChArUco board's by id with those not found
// missing; nothing when no board is found, and then *miss (when given) says why. For
// callers that take images one at a time (the daemon's calibration sessions).
std::optional<BoardView> detect_board_view(const cv::Mat& image, const CalibrateOptions& options,
                                           BoardMiss* miss = nullptr);

// The board views of options' source (images, a capture folder or corners.vnl) with the
// imager size, and for images each one's detection: the first part of calibrate(), for
// callers that solve the views otherwise (a rig's cameras, calib/rig/rig_calibrate.h).
// Errors as calibrate()'s before its solve ("no_board" when no image holds the board).
Result<CalibrationRun> read_board_views(const CalibrateOptions& options);

// Detects, solves and reports; writes only options.out_corners_vnl (right after
// detection, so the corners survive a solve that fails). Errors (stable codes): "invalid_argument"
// and "out_of_range" (options, the ChArUco board), "io_error" (unreadable inputs),
// "imager_mismatch" (images of different sizes), "too_few_views", "seed_failed", "solve_failed",
// "bad_lensmodel", "unknown_sensor", and those of the corners.vnl reader.
Result<CalibrationRun> calibrate(const CalibrateOptions& options);

// Writes the outputs named in `options` (cameramodel, OpenCV YAML, plots, JSON report)
// and returns the JSON report as written: run->report_json plus "files" (the paths
// written) and "plots_skipped" (plots that could not be made, with the reason). Error
// "no_opencv_equivalent" when OpenCV YAML is asked for a model OpenCV cannot represent,
// "io_error".
Result<nlohmann::json> write_calibration_outputs(CalibrationRun* run,
                                                 const CalibrateOptions& options);

// One image file's board as a view (corners in mrcal's order, named after the file), or
// nullopt when the board is not in it; *width_px and *height_px get the image's size.
// Errors: "io_error" (unreadable, or not yet whole), and the detector choice's
// ("invalid_argument", "out_of_range") as calibrate(). The folder watch of the guided
// calibration (guided_session.h) detects each new image with it.
Result<std::optional<BoardView>> detect_image_view(const std::filesystem::path& image,
                                                   const CalibrateOptions& options, int* width_px,
                                                   int* height_px);

// calibrate() then write_calibration_outputs(): the daemon's entry point for
// POST /v1/calibrations. Returns the JSON report (what `--report` writes).
Result<nlohmann::json> calibrate_folder(const CalibrateOptions& options);

}  // namespace camlab::calib
