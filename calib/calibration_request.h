// The one check of a calibration's request: the board, the detector, the lens model, the
// sensor and the source, each rule written once with one error code, for `camlab
// calibrate` (and its --watch), POST /v1/calibrations and the calibration sessions alike.
// The same bad request gets the same code and message from the CLI and from camlabd.
//
// Reentrant.
#pragma once

#include "base/result.h"
#include "calib/calibrate.h"

namespace camlab::calib {

// Limits, with their units. A board's corners and spacing set the problem's size and its
// geometry: 1 um between corners is below any printed or etched target that a camera can
// resolve (1e-300 m would make every pose degenerate), 10 m above any board.
inline constexpr int kBoardInnerCornersMin = 2, kBoardInnerCornersMax = 100;  // each way
inline constexpr double kBoardSpacingMinM = 1e-6, kBoardSpacingMaxM = 10;
// Pixel pitch: the smallest sensor pixels made are about 0.56 um; 100 um is a thermal
// camera's.
inline constexpr double kPixelPitchMinUm = 0.3, kPixelPitchMaxUm = 100;
inline constexpr int kImagerSideMaxPx = 65535;

// Every rule of `options` that does not need an image: one source; the board (inner
// corners, spacing); the detector and, for ChArUco, its markers and dictionary; the lens
// model (known to mrcal, within lens_model.h's limits); the pixel pitch; the imager size.
// With `need_source` false the source is not checked (a session takes its images later).
// Codes: "invalid_argument" (a missing or contradictory choice), "out_of_range" (a number
// outside its limits, named in the message), "unsupported" (a detector that cannot find
// that board), "bad_lensmodel" (a name mrcal does not know).
Status check_calibration_request(const CalibrateOptions& options, bool need_source = true);

}  // namespace camlab::calib
