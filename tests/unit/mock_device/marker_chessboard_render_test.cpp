// The chessboard's circle markers (scene_spec.h, "markers"): a fronto-parallel board of
// 4 x 3 inner corners, 30 mm squares, 0.5 m in front of the example wide camera, at the
// image's centre (733 px focal length: 44 px a square). The three marker squares are where the rule
// says, in the truth and in the image: each disc (radius 0.17 squares) is the other colour
// than its square 0.1 squares from its centre, and its square's colour 0.25 squares out;
// a square without a marker is one colour at its centre. A non-boolean "markers" is an
// error that names the field.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "test_specs.h"

namespace camlab::mock {
namespace {

nlohmann::json marker_scene() {
  return {{"illuminance_lux", 800},
          {"targets",
           {{{"type", "chessboard"},
             {"inner_corners", {4, 3}},
             {"square_m", 0.03},
             {"markers", true},
             {"pose", {0, 0, 0, -0.045, -0.03, 0.5}}}}}};
}

// Mean of the 3 x 3 pixels around p (the frame's DN, black level included).
double mean_around(const cv::Mat& image, cv::Point2d p) {
  double sum = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      sum += image.at<uint16_t>(static_cast<int>(std::lround(p.y)) + dy,
                                static_cast<int>(std::lround(p.x)) + dx);
  return sum / 9;
}

TEST(MarkerChessboardRender, DiscsSitInTheRuleSquaresInTheOtherColour) {
  auto camera = load_camera_spec(std::filesystem::path(CAMLAB_SOURCE_DIR) /
                                 "mock_device/examples/camera_wide_1280x800.json");
  ASSERT_TRUE(camera.ok());
  auto scene = parse_scene_spec(marker_scene());
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto r = Renderer::create(std::move(*camera), std::move(*scene));
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto frame = r->render(r->default_settings(), 0, RenderOptions{});
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const nlohmann::json& target = frame->truth["targets"][0];
  // The rule for 4 x 3 inner corners (5 x 4 squares): the middle square (2, 2) is dark, so
  // the light marker square is (1, 2), with the dark ones above it and right of it.
  EXPECT_EQ(target["marker_squares"], nlohmann::json({{1, 2}, {1, 1}, {2, 2}}));
  const nlohmann::json& corners = target["corners_px"];
  auto corner = [&](int i, int j) {
    const auto& c = corners[static_cast<size_t>(j * 4 + i)];
    return cv::Point2d(c[0].get<double>(), c[1].get<double>());
  };
  // Square (a, b) spans inner corners (a - 1 .. a, b - 1 .. b); its side in px.
  const double side_px = cv::norm(corner(1, 0) - corner(0, 0));

  ASSERT_NEAR(side_px, 44, 1.5);
  const double dark = mean_around(frame->image, 0.5 * (corner(2, 0) + corner(3, 1)));
  const double light = mean_around(frame->image, 0.5 * (corner(1, 0) + corner(2, 1)));
  ASSERT_GT(light, 2 * dark);  // the centres of squares (3, 1), dark, and (2, 1), light
  const double mid = 0.5 * (dark + light);
  struct Square {
    int a, b;
    bool dark, marker;
  };
  for (const Square& s :
       {Square{1, 2, false, true}, Square{1, 1, true, true}, Square{2, 2, true, true},
        Square{3, 2, false, false}, Square{2, 1, false, false}, Square{3, 1, true, false}}) {
    const cv::Point2d centre = 0.25 * (corner(s.a - 1, s.b - 1) + corner(s.a, s.b - 1) +
                                       corner(s.a - 1, s.b) + corner(s.a, s.b));
    const bool inner_dark = mean_around(frame->image, centre + cv::Point2d(0.1 * side_px, 0)) < mid;
    const bool outer_dark =
        mean_around(frame->image, centre + cv::Point2d(0, 0.25 * side_px)) < mid;
    EXPECT_EQ(outer_dark, s.dark) << "square " << s.a << "," << s.b;
    EXPECT_EQ(inner_dark, s.dark != s.marker) << "square " << s.a << "," << s.b;
  }
}

TEST(MarkerChessboardRender, MarkersMustBeABoolean) {
  nlohmann::json scene = marker_scene();
  scene["targets"][0]["markers"] = "yes";
  auto s = parse_scene_spec(scene);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("markers"), std::string::npos) << s.error().message;
}

}  // namespace
}  // namespace camlab::mock
