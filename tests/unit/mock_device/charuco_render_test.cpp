// The virtual camera's ChArUco target: its spec's checks, its pattern against the board
// OpenCV draws (cv::aruco::CharucoBoard::draw, an independent picture of the same board),
// the renderer's exact paths against its own pattern and against many samples, and the
// truth's corners against a projection written out here with mrcal.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "image/aruco_dictionary.h"
#include "mock_device/render/charuco_pattern.h"
#include "mock_device/spec/mrcal_api.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

using json = nlohmann::json;

const std::filesystem::path kExamples =
    std::filesystem::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";

json charuco_target(int cols, int rows, double square_m, double marker_m, const char* dictionary) {
  return {{"type", "charuco"},        {"squares", {cols, rows}},
          {"square_m", square_m},     {"marker_m", marker_m},
          {"dictionary", dictionary}, {"pose", {{"position_m", {0.0, 0.0, 1.0}}}}};
}

Result<SceneSpec> scene_with(const json& target) {
  return parse_scene_spec({{"targets", {target}}});
}

TEST(CharucoSpec, ParsesTheBoardAndItsInnerCorners) {
  auto scene = scene_with(charuco_target(11, 8, 0.06, 0.045, "DICT_4X4_50"));
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const TargetSpec& t = scene->targets[0];
  EXPECT_EQ(t.type, TargetType::kCharuco);
  EXPECT_EQ(t.corners_cols, 10);
  EXPECT_EQ(t.corners_rows, 7);
  EXPECT_DOUBLE_EQ(t.marker_m, 0.045);
  EXPECT_EQ(t.dictionary, "DICT_4X4_50");
  // The extent: the squares and a one-square quiet zone around them.
  EXPECT_DOUBLE_EQ(t.x_min_m(), -0.12);
  EXPECT_DOUBLE_EQ(t.x_max_m(), 0.66);
  EXPECT_DOUBLE_EQ(t.y_max_m(), 0.48);
}

struct BadCharuco {
  const char* description;
  json target;
  ErrorCode code;
  const char* expected_in_message;
};

// Test names and failures show the case, not the struct's bytes.
void PrintTo(const BadCharuco& c, std::ostream* os) { *os << c.description; }

class BadCharucoSpec : public ::testing::TestWithParam<BadCharuco> {};

TEST_P(BadCharucoSpec, IsRefusedSayingWhy) {
  auto scene = scene_with(GetParam().target);
  ASSERT_FALSE(scene.ok()) << GetParam().description;
  EXPECT_EQ(scene.error().code, GetParam().code) << scene.error().message;
  EXPECT_NE(scene.error().message.find(GetParam().expected_in_message), std::string::npos)
      << scene.error().message;
  EXPECT_NE(scene.error().message.find("scene.targets[0]"), std::string::npos)
      << scene.error().message;
}

json with(json target, const char* key, json value) {
  target[key] = std::move(value);
  return target;
}

const json kGood = charuco_target(11, 8, 0.06, 0.045, "DICT_4X4_50");

INSTANTIATE_TEST_SUITE_P(
    Charuco, BadCharucoSpec,
    ::testing::Values(BadCharuco{"marker as large as the square", with(kGood, "marker_m", 0.06),
                                 ErrorCode::kOutOfRange, "must be smaller than square_m = 0.06"},
                      BadCharuco{"marker larger than the square", with(kGood, "marker_m", 0.08),
                                 ErrorCode::kOutOfRange, "marker_m = 0.08"},
                      BadCharuco{"unknown dictionary", with(kGood, "dictionary", "DICT_3X3_9"),
                                 ErrorCode::kInvalidArgument,
                                 "unknown ArUco dictionary \"DICT_3X3_9\""},
                      BadCharuco{"more light squares than markers",
                                 with(kGood, "squares", json{12, 9}), ErrorCode::kOutOfRange,
                                 "needs 54 markers; DICT_4X4_50 has 50"},
                      BadCharuco{"squares not integers", with(kGood, "squares", json{11.5, 8}),
                                 ErrorCode::kInvalidArgument, "two integers"},
                      BadCharuco{"too few squares", with(kGood, "squares", json{2, 8}),
                                 ErrorCode::kOutOfRange, "squares"}),
    [](const auto& info) { return "case" + std::to_string(info.index); });

TEST(CharucoSpec, MissingFieldsAreNamed) {
  for (const char* key : {"marker_m", "dictionary", "squares", "square_m"}) {
    json target = kGood;
    target.erase(key);
    auto scene = scene_with(target);
    ASSERT_FALSE(scene.ok()) << key;
    EXPECT_NE(scene.error().message.find(std::string(".") + key + " is required"),
              std::string::npos)
        << scene.error().message;
  }
}

// The pattern against OpenCV's own drawing of the same board at 120 px a square: every
// drawn pixel well inside a region of one colour (its 5 x 5 neighbourhood uniform) has the
// pattern's colour at its centre.
void expect_pattern_is_opencvs(int cols, int rows, const char* dictionary, double marker_share) {
  const double square_m = 0.05, marker_m = marker_share * square_m;
  auto scene = scene_with(charuco_target(cols, rows, square_m, marker_m, dictionary));
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto pattern = CharucoPattern::create(scene->targets[0]);
  ASSERT_TRUE(pattern.ok()) << pattern.error().message;
  const auto d = image::find_aruco_dictionary(dictionary);
  auto board = cv::aruco::CharucoBoard::create(cols, rows, static_cast<float>(square_m),
                                               static_cast<float>(marker_m),
                                               cv::aruco::getPredefinedDictionary(d->opencv_id));
  const int px = 120;
  cv::Mat drawn;
  board->draw(cv::Size(cols * px, rows * px), drawn, 0, 1);
  ASSERT_EQ(drawn.cols, cols * px);
  cv::Mat lo, hi;
  cv::erode(drawn, lo, cv::Mat::ones(5, 5, CV_8U));
  cv::dilate(drawn, hi, cv::Mat::ones(5, 5, CV_8U));
  int compared = 0, differ = 0;
  for (int y = 0; y < drawn.rows; ++y)
    for (int x = 0; x < drawn.cols; ++x) {
      if (lo.at<uint8_t>(y, x) != hi.at<uint8_t>(y, x)) continue;
      // Board coordinates of the pixel's centre, then the target's (origin at the first
      // inner corner).
      const double u = (x + 0.5) / px * square_m - square_m;
      const double v = (y + 0.5) / px * square_m - square_m;
      ++compared;
      differ += (*pattern)->light_at(u, v) != (drawn.at<uint8_t>(y, x) > 128) ? 1 : 0;
    }
  EXPECT_GT(compared, drawn.total() / 2);
  EXPECT_EQ(differ, 0) << cols << "x" << rows << " " << dictionary << ": " << differ << " of "
                       << compared << " pixels differ from cv::aruco::CharucoBoard::draw";
}

TEST(CharucoPattern, IsTheBoardOpenCvDraws) {
  expect_pattern_is_opencvs(11, 8, "DICT_4X4_50", 0.75);
  expect_pattern_is_opencvs(5, 7, "DICT_5X5_100", 0.7);  // odd rows
  expect_pattern_is_opencvs(6, 5, "DICT_6X6_250", 0.8);  // even columns
}

TEST(CharucoPattern, MarkersFillTheLightSquaresInRowMajorOrder) {
  auto scene = scene_with(charuco_target(5, 4, 0.04, 0.03, "DICT_4X4_50"));
  auto pattern = CharucoPattern::create(scene->targets[0]);
  ASSERT_TRUE(pattern.ok());
  // Row 0: squares 1, 3 light; row 1: 0, 2, 4; ...
  EXPECT_EQ((*pattern)->marker_in_square(0, 0), -1);
  EXPECT_EQ((*pattern)->marker_in_square(1, 0), 0);
  EXPECT_EQ((*pattern)->marker_in_square(3, 0), 1);
  EXPECT_EQ((*pattern)->marker_in_square(0, 1), 2);
  EXPECT_EQ((*pattern)->marker_in_square(4, 1), 4);
  EXPECT_EQ((*pattern)->marker_in_square(4, 3), 9);
  EXPECT_EQ((*pattern)->marker_in_square(5, 0), -1);  // off the board
  // The quiet zone is light, the top-left square dark.
  EXPECT_TRUE((*pattern)->light_at(-0.045, -0.045));
  EXPECT_FALSE((*pattern)->light_at(-0.02, -0.02));
}

// structure_in says what the pattern holds over a box; checked on random boxes of every
// size against the pattern sampled densely inside them.
TEST(CharucoPattern, StructureOfABoxIsWhatItHolds) {
  auto scene = scene_with(charuco_target(5, 4, 0.04, 0.03, "DICT_4X4_50"));
  auto pattern = CharucoPattern::create(scene->targets[0]);
  ASSERT_TRUE(pattern.ok());
  const CharucoPattern& p = **pattern;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> where(-0.07, 0.19), size_m(0, 0.012);
  int counts[3] = {0, 0, 0};
  for (int trial = 0; trial < 4000; ++trial) {
    const double u0 = where(rng), v0 = where(rng) * 0.8;
    const double u1 = u0 + size_m(rng) * (trial % 3 == 0 ? 0.1 : 1);
    const double v1 = v0 + size_m(rng) * (trial % 5 == 0 ? 0.1 : 1);
    const CharucoPattern::Structure s = p.structure_in(u0, u1, v0, v1);
    ++counts[s.kind];
    if (s.kind == CharucoPattern::Structure::kComplex) continue;
    const int n = 24;
    bool seen[2][2] = {{false, false}, {false, false}};  // [side][light]
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const double u = u0 + (u1 - u0) * (i + 0.01) / (n + 0.02);
        const double v = v0 + (v1 - v0) * (j + 0.01) / (n + 0.02);
        const double f = s.e_u * u + s.e_v * v - s.e0;
        if (s.kind == CharucoPattern::Structure::kOneLine && std::fabs(f) < 1e-12) continue;
        const int side = s.kind == CharucoPattern::Structure::kOneLine && f > 0 ? 1 : 0;
        seen[side][p.light_at(u, v) ? 1 : 0] = true;
      }
    // Each side holds one value, the one structure_in says.
    EXPECT_FALSE(seen[0][!s.negative_light]) << "box " << u0 << " " << u1 << " " << v0 << " " << v1;
    if (s.kind == CharucoPattern::Structure::kOneLine) {
      EXPECT_FALSE(seen[1][!s.positive_light]) << "box " << u0 << " " << u1 << " " << v0;
      EXPECT_NE(s.negative_light, s.positive_light);
    }
  }
  // Every kind occurs, so each was checked.
  EXPECT_GT(counts[CharucoPattern::Structure::kConstant], 300);
  EXPECT_GT(counts[CharucoPattern::Structure::kOneLine], 300);
  EXPECT_GT(counts[CharucoPattern::Structure::kComplex], 300);
}

// The automatic rule's exact paths (flat patches, straight edges) on a tilted ChArUco board
// through a distorted lens, against the uniform path with 1024 samples a pixel.
TEST(CharucoRender, AgreesWithManyUniformSamples) {
  json camera = testing::pinhole_camera_json(128, 96);
  camera["lens"]["model"] = "LENSMODEL_OPENCV4";
  camera["lens"]["distortion"] = {-0.05, 0.01, 0.0, 0.0};
  json target = charuco_target(4, 3, 0.01, 0.0075, "DICT_4X4_50");
  target["pose"] = {{"position_m", {-0.02, -0.012, 0.8}}, {"rotation_deg", {-20, 15, 5}}};
  const json scene = {
      {"illuminance_lux", 1000}, {"background_reflectance", 0.3}, {"targets", {target}}};
  Renderer renderer = testing::make_renderer(camera, scene);
  RenderSettings settings = renderer.default_settings();
  settings.f_number = 2.0;
  settings.focus_position = 80;  // s about 0.8 m: the board within a pixel or two of focus
  auto fast = renderer.integrate_scene(settings, 0, RenderOptions{});
  ASSERT_TRUE(fast.ok()) << fast.error().message;
  EXPECT_GT(fast->stats.flat_share, 0.3);
  EXPECT_GT(fast->stats.edge_share, 0.05);
  RenderOptions reference_options;
  reference_options.aperture_samples = 1024;
  reference_options.seed = 99;
  auto reference = renderer.integrate_scene(settings, 0, reference_options);
  ASSERT_TRUE(reference.ok());
  cv::Mat hi, lo;
  cv::dilate(reference->reflectance, hi, cv::Mat());
  cv::erode(reference->reflectance, lo, cv::Mat());
  const cv::Mat mask = (hi - lo) > 0.005 * 0.8;
  ASSERT_GT(cv::countNonZero(mask), 1000);
  auto rms_and_bias = [&](const cv::Mat& image) {
    cv::Mat diff = image - reference->reflectance;
    return std::pair{std::sqrt(cv::mean(diff.mul(diff), mask)[0]) / 0.8,
                     cv::mean(diff, mask)[0] / 0.8};
  };
  const auto [rms, bias] = rms_and_bias(fast->reflectance);
  // The uniform path at the count the rule gives the frame's largest blur: every pixel
  // sampled at random. The exact paths must do better, and be unbiased.
  RenderOptions uniform_options;
  uniform_options.aperture_samples = std::max(1, fast->stats.aperture_samples);
  uniform_options.seed = 5;
  auto uniform = renderer.integrate_scene(settings, 0, uniform_options);
  ASSERT_TRUE(uniform.ok());
  const auto [uniform_rms, uniform_bias] = rms_and_bias(uniform->reflectance);
  EXPECT_LT(rms, uniform_rms) << "adaptive " << rms << ", " << uniform_options.aperture_samples
                              << " uniform samples " << uniform_rms << " (share of the contrast)";
  EXPECT_LT(std::fabs(bias), 0.001);
}

// The truth's corners against a projection written out here: the board's corner (i, j)
// at (i, j) x square in the target frame, carried into the camera by mrcal's own
// transform of the truth's rt_cam_target and projected by mrcal through the truth's lens.
TEST(CharucoRender, TruthCornersAreTheBoardsCornersProjected) {
  auto camera = load_camera_spec(kExamples / "camera_wide_1280x800.json");
  auto scene = load_scene_spec(kExamples / "scene_charuco_calibration.json");
  ASSERT_TRUE(camera.ok() && scene.ok());
  auto r = Renderer::create(std::move(*camera), std::move(*scene));
  ASSERT_TRUE(r.ok()) << r.error().message;
  int partial_views = 0, off_imager = 0;
  for (int view : {0, 5, 27, 34}) {
    auto frame = r->render(r->default_settings(), view, RenderOptions{.noise = false});
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    const json& truth = frame->truth;
    const json& board = truth["targets"][0];
    ASSERT_EQ(board["type"], "charuco");
    ASSERT_EQ(board["squares"], json({11, 8}));
    ASSERT_EQ(board["inner_corners"], json({10, 7}));
    EXPECT_EQ(board["dictionary"], "DICT_4X4_50");
    const std::vector<double> rt = board["rt_cam_target"];
    const std::vector<double> intrinsics = truth["intrinsics"];
    mrcal_lensmodel_t lensmodel;
    ASSERT_TRUE(
        mrcal_lensmodel_from_name(&lensmodel, truth["lensmodel"].get<std::string>().c_str()));
    const json& corners = board["corners_px"];
    const json& projected = board["corners_projected_px"];
    ASSERT_EQ(corners.size(), 70u);
    int missing = 0;
    for (int j = 0; j < 7; ++j)
      for (int i = 0; i < 10; ++i) {
        const int id = j * 10 + i;
        mrcal_point3_t p = {.x = i * 0.06, .y = j * 0.06, .z = 0}, pc;
        mrcal_transform_point_rt(pc.xyz, nullptr, nullptr, rt.data(), p.xyz);
        mrcal_point2_t q;
        ASSERT_TRUE(mrcal_project(&q, nullptr, nullptr, &pc, 1, &lensmodel, intrinsics.data()));
        ASSERT_FALSE(projected[id].is_null());
        EXPECT_NEAR(projected[id][0].get<double>(), q.x, 1e-9) << "view " << view << " id " << id;
        EXPECT_NEAR(projected[id][1].get<double>(), q.y, 1e-9);
        const bool on_imager = q.x >= -0.5 && q.y >= -0.5 && q.x <= 1279.5 && q.y <= 799.5;
        EXPECT_EQ(corners[id].is_null(), !on_imager) << "view " << view << " id " << id;
        if (on_imager) {
          EXPECT_EQ(corners[id], projected[id]);
        } else {
          ++missing;
        }
      }
    off_imager += missing;
    partial_views += missing > 0 ? 1 : 0;
  }
  // Views 27 and 34 are cut by the frame's edges (the example's partial views).
  EXPECT_GE(partial_views, 2);
  EXPECT_GT(off_imager, 40);
}

}  // namespace
}  // namespace camlab::mock
