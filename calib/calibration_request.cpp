#include "calib/calibration_request.h"

#include <cmath>
#include <string>

#include "base/format.h"
#include "calib/corners/charuco_corners.h"
#include "calib/corners/chessboard_detector.h"
#include "calib/lens_model.h"

namespace camlab::calib {

namespace {

Status check_source(const CalibrateOptions& o) {
  const int sources = !o.images_dir.empty() + !o.job_dir.empty() + !o.corners_vnl.empty();
  if (sources != 1)
    return make_error(
        "invalid_argument",
        "give exactly one source: a folder of images, a capture folder, or corners.vnl");
  if (!o.corners_vnl.empty() && o.imager_width_px == 0)
    return make_error("invalid_argument",
                      "corners.vnl needs the imager size (it does not record it)");
  return {};
}

Status check_board(const BoardSpec& b) {
  if (b.cols < kBoardInnerCornersMin || b.rows < kBoardInnerCornersMin ||
      b.cols > kBoardInnerCornersMax || b.rows > kBoardInnerCornersMax)
    return make_error("out_of_range", "the board's inner corners " + std::to_string(b.cols) + "x" +
                                          std::to_string(b.rows) + " must be in [" +
                                          std::to_string(kBoardInnerCornersMin) + ", " +
                                          std::to_string(kBoardInnerCornersMax) + "] each way");
  if (!(b.spacing_m >= kBoardSpacingMinM && b.spacing_m <= kBoardSpacingMaxM))
    return make_error("out_of_range", "the corner spacing " + format_significant(b.spacing_m) +
                                          " m must be in [" +
                                          format_significant(kBoardSpacingMinM) + ", " +
                                          format_significant(kBoardSpacingMaxM) + "] metres");
  return {};
}

Status check_detector(const CalibrateOptions& o) {
  if (o.detector == "charuco") {
    if (o.charuco_marker_m == 0 || o.charuco_dictionary.empty())
      return make_error("invalid_argument",
                        "a ChArUco board needs its markers: the marker's side in metres (its "
                        "black border included) and the dictionary (e.g. DICT_4X4_50)");
    return check_charuco_board({o.board.cols + 1, o.board.rows + 1, o.board.spacing_m,
                                o.charuco_marker_m, o.charuco_dictionary});
  }
  if (o.charuco_marker_m != 0 || !o.charuco_dictionary.empty())
    return make_error("invalid_argument",
                      "a marker size and a dictionary describe a ChArUco board: use them with "
                      "the charuco detector");
  return check_chessboard_detector(o.detector, o.board.cols, o.board.rows);
}

Status check_model(const std::string& model) {
  if (model == "auto") return {};
  // Any imager size checks the name: it only configures a bare splined model's grid.
  std::string configured;
  CAMLAB_ASSIGN(configured, configured_lensmodel(model, 1280, 800, 90));
  if (auto params = lensmodel_param_count(configured); !params) return params.error();
  return {};
}

Status check_sensor(const CalibrateOptions& o) {
  if (o.imager_width_px < 0 || o.imager_height_px < 0 ||
      (o.imager_width_px > 0) != (o.imager_height_px > 0))
    return make_error("invalid_argument",
                      "the imager size must be given as both width and height in px");
  if (o.imager_width_px > kImagerSideMaxPx || o.imager_height_px > kImagerSideMaxPx)
    return make_error("out_of_range", "the imager's sides must be at most " +
                                          std::to_string(kImagerSideMaxPx) + " px");
  // 0: not given (no focal length in mm).
  if (o.pixel_pitch_um != 0 &&
      !(o.pixel_pitch_um >= kPixelPitchMinUm && o.pixel_pitch_um <= kPixelPitchMaxUm))
    return make_error("out_of_range", "the pixel pitch " + format_significant(o.pixel_pitch_um) +
                                          " um must be in [" +
                                          format_significant(kPixelPitchMinUm) + ", " +
                                          format_significant(kPixelPitchMaxUm) + "] micrometres");
  if (!(o.focal_guess_px >= 0) || !std::isfinite(o.focal_guess_px))
    return make_error("out_of_range", "the focal length guess must be >= 0 px (0: none)");
  return {};
}

}  // namespace

Status check_calibration_request(const CalibrateOptions& options, bool need_source) {
  if (need_source)
    if (Status s = check_source(options); !s) return s;
  if (Status s = check_board(options.board); !s) return s;
  if (Status s = check_detector(options); !s) return s;
  if (Status s = check_model(options.model); !s) return s;
  return check_sensor(options);
}

}  // namespace camlab::calib
