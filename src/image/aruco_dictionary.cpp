#include "image/aruco_dictionary.h"

#include <array>

#include <opencv2/aruco/dictionary.hpp>

namespace camlab::image {

namespace {

struct Named {
  const char* name;
  cv::aruco::PREDEFINED_DICTIONARY_NAME id;
};

// OpenCV 4.6's predefined dictionaries, in its enum's order.
constexpr std::array kDictionaries = {
    Named{"DICT_4X4_50", cv::aruco::DICT_4X4_50},
    Named{"DICT_4X4_100", cv::aruco::DICT_4X4_100},
    Named{"DICT_4X4_250", cv::aruco::DICT_4X4_250},
    Named{"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
    Named{"DICT_5X5_50", cv::aruco::DICT_5X5_50},
    Named{"DICT_5X5_100", cv::aruco::DICT_5X5_100},
    Named{"DICT_5X5_250", cv::aruco::DICT_5X5_250},
    Named{"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
    Named{"DICT_6X6_50", cv::aruco::DICT_6X6_50},
    Named{"DICT_6X6_100", cv::aruco::DICT_6X6_100},
    Named{"DICT_6X6_250", cv::aruco::DICT_6X6_250},
    Named{"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
    Named{"DICT_7X7_50", cv::aruco::DICT_7X7_50},
    Named{"DICT_7X7_100", cv::aruco::DICT_7X7_100},
    Named{"DICT_7X7_250", cv::aruco::DICT_7X7_250},
    Named{"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
    Named{"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
    Named{"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
    Named{"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
    Named{"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
    Named{"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
};

}  // namespace

std::string aruco_dictionary_names() {
  std::string out;
  for (const Named& d : kDictionaries) out += (out.empty() ? "" : ", ") + std::string(d.name);
  return out;
}

Result<ArucoDictionary> find_aruco_dictionary(std::string_view name) {
  for (const Named& d : kDictionaries) {
    if (name != d.name) continue;
    const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(d.id);
    ArucoDictionary out;
    out.name = d.name;
    out.opencv_id = static_cast<int>(d.id);
    out.marker_bits = dict->markerSize;
    out.marker_count = dict->bytesList.rows;
    return out;
  }
  return make_error("invalid_argument", "unknown ArUco dictionary \"" + std::string(name) +
                                            "\"; known: " + aruco_dictionary_names());
}

Result<std::vector<uint8_t>> aruco_marker_cells(const ArucoDictionary& dictionary, int id) {
  if (id < 0 || id >= dictionary.marker_count)
    return make_error("out_of_range", "marker id " + std::to_string(id) + " is outside " +
                                          dictionary.name + "'s 0 .. " +
                                          std::to_string(dictionary.marker_count - 1));
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(
      static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(dictionary.opencv_id));
  // The first of the four rotations stored per marker is the marker as drawn.
  const cv::Mat bits = cv::aruco::Dictionary::getBitsFromByteList(
      dict->bytesList.rowRange(id, id + 1), dictionary.marker_bits);
  const int n = dictionary.marker_bits + 2;
  std::vector<uint8_t> cells(static_cast<size_t>(n * n), 0);  // the border stays black
  for (int r = 0; r < dictionary.marker_bits; ++r)
    for (int c = 0; c < dictionary.marker_bits; ++c)
      cells[static_cast<size_t>((r + 1) * n + c + 1)] = bits.at<uint8_t>(r, c) ? 1 : 0;
  return cells;
}

}  // namespace camlab::image
