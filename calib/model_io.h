// Output files of a calibration: mrcal's .cameramodel at full precision (through
// src/image's writer) and OpenCV's YAML (camera_matrix, distortion_coefficients).
//
// Reentrant.
#pragma once

#include <string>

#include "base/result.h"
#include "calib/lens_model.h"

namespace camlab::calib {

// .cameramodel text (%.17g), camera at the reference frame. `comment` becomes '#' lines.
std::string cameramodel_text(const LensModel& model, const std::string& comment);

// Whether OpenCV can represent the model: PINHOLE and OPENCV4/5/8/12.
bool has_opencv_equivalent(const LensModel& model);

// OpenCV FileStorage YAML with image_width, image_height, camera_matrix (3x3) and
// distortion_coefficients (1xN, OpenCV's order, which is mrcal's). Error
// "no_opencv_equivalent" for other models.
Result<std::string> opencv_yaml_text(const LensModel& model);

}  // namespace camlab::calib
