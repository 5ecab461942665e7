// Output files of a calibration: mrcal's .cameramodel at full precision (through
// src/image's writer), with or without mrcal's optimization_inputs, and OpenCV's YAML
// (camera_matrix, distortion_coefficients).
//
// Reentrant.
#pragma once

#include <array>
#include <string>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/lens_model.h"
#include "calib/solver.h"

namespace camlab::calib {

// .cameramodel text (%.17g). `comment` becomes '#' lines. For models that come from no
// single-camera solve (a truth, a conversion, a rig's camera): `rt_cam_ref` is mrcal's
// extrinsics (reference -> camera; zero: the camera is the reference).
std::string cameramodel_text(const LensModel& model, const std::string& comment,
                             const std::array<double, 6>& rt_cam_ref = {});

// .cameramodel text of a solve (%.17g), with 'icam_intrinsics': 0 and mrcal 2.2's
// 'optimization_inputs': the final problem `solution` was solved from `data` (the same
// CalibrationData), as mrcal-calibrate-cameras stores it, so mrcal's tools that need the
// solve work on camlab's models: mrcal-show-projection-uncertainty, mrcal-show-residuals*,
// mrcal.projection_uncertainty(), mrcal.optimizer_callback(**m.optimization_inputs()).
//
// The inputs are camlab's export of the problem (uncertainty.h,
// mrcal_optimization_inputs) stored as mrcal stores them (npz_writer.h): float64 arrays,
// int32 indices, 0-d bools and strings, None as ''; the view names become 'imagepaths'.
// The observation weights are exactly those of the last stage when the solve kept its
// state (Solution::covariance); otherwise they are rebuilt from the solution: the corners'
// weights, x 1e-3 in down-weighted views, -1 for missing corners and rejected outliers
// (a corner mrcal rejected inside a down-weighted view cannot be told apart there and
// keeps its 1e-3 weight). 'do_apply_outlier_rejection' is False: the weights already mark
// the outliers, so mrcal.optimize(**inputs) stays at this optimum instead of rejecting more.
//
// Size: ~19 bytes of text per board corner (x, y, weight as float64, deflated, base-85;
// 30 without deflate), e.g. 107 kB for 40 views of a 14 x 10 board (416 bytes without).
// Errors: "invalid_argument" when `data` is not the data of `solution` (view indices out
// of range, corner counts that differ from the board); "internal" if the export of
// uncertainty.h no longer has the shape this writer expects (a bug).
Result<std::string> cameramodel_text_with_inputs(const Solution& solution,
                                                 const CalibrationData& data,
                                                 const std::string& comment);

// Whether OpenCV can represent the model: PINHOLE and OPENCV4/5/8/12.
bool has_opencv_equivalent(const LensModel& model);

// OpenCV FileStorage YAML with image_width, image_height, camera_matrix (3x3) and
// distortion_coefficients (1xN, OpenCV's order, which is mrcal's). Error
// "no_opencv_equivalent" for other models.
Result<std::string> opencv_yaml_text(const LensModel& model);

}  // namespace camlab::calib
