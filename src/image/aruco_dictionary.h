// The predefined ArUco marker dictionaries of OpenCV 4.6's aruco module (cv::aruco,
// libopencv-contrib-dev), by name: what a ChArUco board is made of. The virtual camera
// draws its ChArUco target from these bits, and the ChArUco detector
// (calib/corners/charuco_corners.h) looks the same names up, so both sides mean the same
// dictionary by the same name. The bits are data; nothing here detects anything.
//
// Reentrant: the dictionaries are OpenCV's immutable tables.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"

namespace camlab::image {

struct ArucoDictionary {
  std::string name;      // "DICT_4X4_50": cv::aruco's PREDEFINED_DICTIONARY_NAME spelling
  int opencv_id = 0;     // the cv::aruco::PREDEFINED_DICTIONARY_NAME value
  int marker_bits = 0;   // data bits per side, without the one-bit black border
  int marker_count = 0;  // markers in the dictionary (ids 0 .. marker_count - 1)
};

// The dictionary called `name` (exact spelling, e.g. DICT_5X5_100, DICT_APRILTAG_36h11).
// Error "invalid_argument" naming the known dictionaries.
Result<ArucoDictionary> find_aruco_dictionary(std::string_view name);

// Every known name, comma-separated (for error messages and help text).
std::string aruco_dictionary_names();

// Marker `id` of `dictionary` as drawn, without rotation: (marker_bits + 2)^2 cells,
// row-major from the top-left, the outer ring the black border; 1 = white, 0 = black.
// Cell (row, col) of the drawing covers rows and columns of equal width across the
// marker's side, as cv::aruco::Dictionary::drawMarker draws it with borderBits = 1.
// Error "out_of_range" for an id outside the dictionary.
Result<std::vector<uint8_t>> aruco_marker_cells(const ArucoDictionary& dictionary, int id);

}  // namespace camlab::image
