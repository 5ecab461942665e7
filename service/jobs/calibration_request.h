// The board, detector and lens model of a calibration request, as POST /v1/calibrations
// and POST /v1/calibration-sessions take them, checked once for both:
//
//   {"inner_corners": [COLS, ROWS], "spacing_m": 0.04,
//    "detector": "auto" | "saddle" | "opencv" | "mrgingham" | "charuco",
//    "marker_m": 0.03, "dictionary": "DICT_4X4_50",       (ChArUco only)
//    "model": "auto" | "LENSMODEL_...", "pixel_um": 3}
//
// A ChArUco board is named by its inner corners as a chessboard is (its squares are one
// more each way) and spacing_m is its square's side.
//
// Reentrant.
#pragma once

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "calib/calibrate.h"

namespace camlab::service {

// The fields above from `body`, normalised (defaults filled in), or the error a client can
// act on ("invalid_request", "out_of_range", "unsupported", "bad_lensmodel"). Other
// fields of `body` are left to the caller.
Result<nlohmann::json> normalised_calibration_fields(const nlohmann::json& body);

// The calibration options for normalised fields (the source and outputs left empty).
calib::CalibrateOptions calibration_options(const nlohmann::json& normalised);

}  // namespace camlab::service
