// Plots of a calibration (`camlab calibrate --plots DIR`), as PNG through src/analysis's
// plot helper:
//   residuals.png           residual vectors over the imager (scaled; outliers in red)
//   residual_histogram.png  histogram of the inlier residuals' x and y components, with
//                           the normal density of the estimated corner noise
//   coverage.png            every observed corner over the imager (inliers, outliers)
//   uncertainty.png         projection uncertainty over the imager (uncertainty.h), at
//                           infinity, worst-direction 1-sigma in px
//   distortion.png          distortion magnitude over the imager: how far the model moves
//                           each pixel from its own pinhole core (same fx, fy, cx, cy)
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/report.h"

namespace camlab::calib {

// Writes the plots into `dir` (created when missing) and returns the files written. A
// plot that cannot be made (e.g. no covariance for the uncertainty map) is skipped and
// named in `skipped` with the reason. Errors: "io_error".
struct PlotFiles {
  std::vector<std::filesystem::path> written;
  std::vector<std::string> skipped;
};
Result<PlotFiles> write_calibration_plots(const std::filesystem::path& dir,
                                          const CalibrationData& data,
                                          const CalibrationReport& report);

}  // namespace camlab::calib
