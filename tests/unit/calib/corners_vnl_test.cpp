// corners.vnl reading and writing (mrcal / mrgingham interop).
#include <gtest/gtest.h>

#include <cmath>

#include "calib/corners/corners_vnl.h"

namespace camlab::calib {
namespace {

const BoardSpec kBoard{2, 2, 0.1};

TEST(CornersVnl, ParsesLevelsMissingCornersAndImagesWithoutBoard) {
  const char* text =
      "## produced by mrgingham\n"
      "# filename x y level\n"
      "a.png 10.5 20.25 0\n"
      "a.png 11 21 1\n"
      "a.png - - -\n"
      "a.png 13 23 2\n"
      "empty.png - - -\n"
      "b.png 1 2 0\n"
      "b.png 3 4 0\n"
      "b.png 5 6 0\n"
      "b.png 7 8 0\n";
  auto views = parse_corners_vnl(text, kBoard);
  ASSERT_TRUE(views.ok()) << views.error().message;
  ASSERT_EQ(views->size(), 2u);
  const auto& a = (*views)[0];
  EXPECT_EQ(a.name, "a.png");
  ASSERT_EQ(a.corners.size(), 4u);
  EXPECT_DOUBLE_EQ(a.corners[0].x_px, 10.5);
  EXPECT_DOUBLE_EQ(a.corners[0].y_px, 20.25);
  EXPECT_DOUBLE_EQ(a.corners[0].weight, 1.0);
  EXPECT_DOUBLE_EQ(a.corners[1].weight, 0.5);  // level 1
  EXPECT_FALSE(a.corners[2].present);
  EXPECT_DOUBLE_EQ(a.corners[3].weight, 0.25);  // level 2
  EXPECT_EQ(a.present_count(), 3);
  EXPECT_EQ((*views)[1].name, "b.png");
  EXPECT_DOUBLE_EQ((*views)[1].corners[3].y_px, 8.0);
}

TEST(CornersVnl, WriteThenReadIsExact) {
  BoardView v;
  v.name = "frame_000001.png";
  v.corners = {{1.0 / 3, 2.0 / 7, 1.0, true},
               {0, 0, 1.0, false},
               {5.125, 6.5, 0.5, true},
               {1e-9, 799.999999999, 0.25, true}};
  auto back = parse_corners_vnl(to_corners_vnl({v}), kBoard);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->size(), 1u);
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ((*back)[0].corners[k].present, v.corners[k].present);
    if (!v.corners[k].present) continue;
    EXPECT_EQ((*back)[0].corners[k].x_px, v.corners[k].x_px);  // bit-exact
    EXPECT_EQ((*back)[0].corners[k].y_px, v.corners[k].y_px);
    EXPECT_DOUBLE_EQ((*back)[0].corners[k].weight, v.corners[k].weight);
  }
}

TEST(CornersVnl, WeightColumnAndThreeColumnForms) {
  auto w =
      parse_corners_vnl("# filename x y weight\nq 1 2 0.5\nq 1 2 1\nq 1 2 1\nq 1 2 1\n", kBoard);
  ASSERT_TRUE(w.ok());
  EXPECT_DOUBLE_EQ((*w)[0].corners[0].weight, 0.5);
  auto three = parse_corners_vnl("# filename x y\nq 1 2\nq - -\nq 1 2\nq 1 2\n", kBoard);
  ASSERT_TRUE(three.ok());
  EXPECT_EQ((*three)[0].present_count(), 3);
}

TEST(CornersVnl, RejectsWrongCornerCountsAndGarbage) {
  auto short_view = parse_corners_vnl("# filename x y level\na 1 2 0\na 1 2 0\nb 1 2 0\n", kBoard);
  ASSERT_FALSE(short_view.ok());
  EXPECT_EQ(short_view.error().code, "bad_vnl");
  // A negative level marks a corner to skip (mrcal's convention), never an infinite
  // weight: the fuzzer's input had level -666666, 0.5^level overflowing to inf.
  auto skipped = parse_corners_vnl("# filename x y level\na 1 2 -666666\n", kBoard);
  if (skipped.ok()) {
    for (const auto& view : *skipped)
      for (const auto& c : view.corners) EXPECT_TRUE(std::isfinite(c.weight));
  }
  auto skipped_row = parse_corners_vnl(
      "# filename x y level\n" +
          [] {
            std::string rows;
            for (int k = 0; k < kBoard.cols * kBoard.rows; ++k)
              rows += std::string("a ") + std::to_string(k) + " 2 " + (k == 1 ? "-3" : "0") + "\n";
            return rows;
          }(),
      kBoard);
  ASSERT_TRUE(skipped_row.ok()) << skipped_row.error().message;
  EXPECT_FALSE((*skipped_row)[0].corners[1].present);
  EXPECT_TRUE((*skipped_row)[0].corners[0].present);
  EXPECT_FALSE(parse_corners_vnl("# filename x y weight\na 1 2 inf\n", kBoard).ok());
  auto garbage = parse_corners_vnl("# filename x y level\na 1 zz 0\n", kBoard);
  ASSERT_FALSE(garbage.ok());
  EXPECT_NE(garbage.error().message.find("line 2"), std::string::npos);
  EXPECT_FALSE(parse_corners_vnl("a 1 2 0\n", kBoard).ok());  // no legend
}

}  // namespace
// Found by the corners_vnl fuzz harness: an image listed again after another image was
// read as a second view of it, which to_corners_vnl then wrote as one image with twice
// the rows (unreadable). An image's rows must be consecutive.
TEST(CornersVnl, RejectsAnImageListedAgainAfterAnother) {
  auto twice = parse_corners_vnl(
      "# filename x y\nq 1 2\nq - -\nq 2 2\nq 1 2\nr - -\nq 1 2\nq - -\nq 2 2\nq 1 2\n", kBoard);
  ASSERT_FALSE(twice.ok());
  EXPECT_EQ(twice.error().code, "bad_vnl");
  EXPECT_NE(twice.error().message.find("'q' appears again"), std::string::npos)
      << twice.error().message;
  EXPECT_NE(twice.error().message.find("line 7"), std::string::npos) << twice.error().message;
}

}  // namespace camlab::calib
