// The input of a calibration: board observations of one camera (a chessboard, or a
// ChArUco board's inner corners).
//
// Corners are in mrcal's order: row-major over the inner corners, corner (i, j) being the
// board point (i * spacing_m, j * spacing_m, 0), i < cols, j < rows; for a ChArUco board
// the index is the corner's ChArUco id. Pixel centres are at integer coordinates (mrcal's
// and OpenCV's convention).
//
// Reentrant: plain value types.
#pragma once

#include <string>
#include <vector>

namespace camlab::calib {

struct BoardSpec {
  int cols = 0;            // inner corners per row
  int rows = 0;            // inner corners per column
  double spacing_m = 0.0;  // distance between neighbouring corners
};

struct CornerObservation {
  double x_px = 0.0;
  double y_px = 0.0;
  double weight = 1.0;   // mrcal's weight: 1 for a full-resolution detection
  bool present = false;  // false: not detected (off the imager, occluded, rejected)
};

struct BoardView {
  std::string name;                        // image file name, or a label
  std::vector<CornerObservation> corners;  // cols * rows, row-major
  // "saddle", "opencv", "mrgingham" or "charuco"; empty when read from corners.vnl
  std::string detector;
  int present_count() const;
};

struct CalibrationData {
  BoardSpec board;
  int imager_width_px = 0;
  int imager_height_px = 0;
  std::vector<BoardView> views;
};

}  // namespace camlab::calib
