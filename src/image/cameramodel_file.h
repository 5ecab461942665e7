// mrcal's .cameramodel text format, written at full precision.
//
// mrcal's own writer prints 6 decimals, which throws away precision the truth of the
// virtual camera (and a calibration) has; this writer prints every double round-trip
// exact (%.17g). The output is a Python-literal dict that mrcal's C reader
// (mrcal_read_cameramodel_string) and its Python tools (mrcal.cameramodel) both load.
// Reading is left to mrcal itself (calib/, mock_device/), which src/ does not link.
//
// A model from a calibration may carry mrcal's 'optimization_inputs' (the solve's whole
// problem, calib/model_io.h) with 'icam_intrinsics'; this writer only places the encoded
// text, which calib/ produces.
//
// Reentrant.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace camlab::image {

struct CameraModelText {
  std::string lensmodel;                 // e.g. "LENSMODEL_OPENCV8", as mrcal names it
  std::vector<double> intrinsics;        // fx, fy, cx, cy (px), then the distortion parameters
  std::array<double, 6> rt_cam_ref{};    // rotation vector (rad) and translation (m)
  std::array<unsigned, 2> imagersize{};  // width, height (px)
  std::string comment;                   // optional; written as '#' lines at the top
  // Optional: the base-85 text of the .npz of mrcal's optimization_inputs (written as the
  // Python bytes literal b'...') and the index of this camera's intrinsics in them.
  std::string optimization_inputs_b85;
  int icam_intrinsics = 0;
};

std::string to_cameramodel_text(const CameraModelText& model);

}  // namespace camlab::image
