// The ArUco dictionaries by name: the lookup, its errors, and each marker's cells against
// the marker OpenCV itself draws (cv::aruco::Dictionary::drawMarker), the picture the
// virtual camera's ChArUco target must reproduce.
#include <gtest/gtest.h>

#include <opencv2/aruco/dictionary.hpp>

#include "image/aruco_dictionary.h"

namespace camlab::image {
namespace {

TEST(ArucoDictionary, FindsPredefinedDictionariesByName) {
  auto d = find_aruco_dictionary("DICT_4X4_50");
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->opencv_id, cv::aruco::DICT_4X4_50);
  EXPECT_EQ(d->marker_bits, 4);
  EXPECT_EQ(d->marker_count, 50);
  auto tag = find_aruco_dictionary("DICT_APRILTAG_36h11");
  ASSERT_TRUE(tag.ok());
  EXPECT_EQ(tag->marker_bits, 6);
  EXPECT_EQ(tag->marker_count, 587);
  auto big = find_aruco_dictionary("DICT_5X5_1000");
  ASSERT_TRUE(big.ok());
  EXPECT_EQ(big->marker_count, 1000);
}

TEST(ArucoDictionary, UnknownNameListsTheKnownOnes) {
  auto d = find_aruco_dictionary("DICT_4x4_50");  // wrong case: names are exact
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(d.error().message.find("DICT_4x4_50"), std::string::npos);
  EXPECT_NE(d.error().message.find("DICT_4X4_50"), std::string::npos) << d.error().message;
  EXPECT_NE(d.error().message.find("DICT_APRILTAG_36h11"), std::string::npos);
}

TEST(ArucoDictionary, MarkerCellsAreWhatOpenCvDraws) {
  for (const char* name : {"DICT_4X4_50", "DICT_5X5_100", "DICT_6X6_250", "DICT_APRILTAG_16h5"}) {
    const ArucoDictionary d = *find_aruco_dictionary(name);
    const auto dict = cv::aruco::getPredefinedDictionary(d.opencv_id);
    const int n = d.marker_bits + 2, cell_px = 10;
    for (int id : {0, 1, 7, d.marker_count - 1}) {
      auto cells = aruco_marker_cells(d, id);
      ASSERT_TRUE(cells.ok());
      ASSERT_EQ(cells->size(), static_cast<size_t>(n * n));
      cv::Mat drawn;
      dict->drawMarker(id, n * cell_px, drawn, 1);
      for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c) {
          const bool white =
              drawn.at<uint8_t>(r * cell_px + cell_px / 2, c * cell_px + cell_px / 2) > 128;
          EXPECT_EQ((*cells)[static_cast<size_t>(r * n + c)], white ? 1 : 0)
              << name << " marker " << id << " cell " << r << "," << c;
        }
    }
  }
}

TEST(ArucoDictionary, MarkerIdOutsideTheDictionaryIsAnError) {
  const ArucoDictionary d = *find_aruco_dictionary("DICT_4X4_50");
  EXPECT_EQ(aruco_marker_cells(d, 50).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(aruco_marker_cells(d, -1).error().code, ErrorCode::kOutOfRange);
}

}  // namespace
}  // namespace camlab::image
