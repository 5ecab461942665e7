// Colour camera and scene specs: a Bayer order, QE per channel, longitudinal chromatic
// aberration, the JPEG quality of the image processor, and RGB reflectances; every bad
// value refused with a message naming the field and what is allowed.
#include <gtest/gtest.h>

#include "test_specs.h"

namespace camlab::mock {
namespace {

TEST(ColourSpec, ABayerSensorReadsItsOrderQeAndFocusShifts) {
  auto spec = parse_camera_spec(testing::colour_camera_json(64, 48, "GBRG"));
  ASSERT_TRUE(spec.ok()) << spec.error().message;
  EXPECT_TRUE(spec->sensor.is_colour());
  EXPECT_EQ(spec->sensor.cfa, "GBRG");
  EXPECT_EQ(spec->sensor.quantum_efficiency_rgb, (std::array<double, 3>{0.45, 0.6, 0.4}));
  EXPECT_DOUBLE_EQ(spec->lens.channel_focal_mm(0), 8.02);
  EXPECT_DOUBLE_EQ(spec->lens.channel_focal_mm(1), 8.0);
  EXPECT_DOUBLE_EQ(spec->lens.channel_focal_mm(2), 7.985);
  EXPECT_EQ(spec->isp.jpeg_quality, 90) << "the default quality";
  // GBRG: row 0 is G B G B, row 1 is R G R G.
  EXPECT_EQ(spec->sensor.channel_at(0, 0), 1);
  EXPECT_EQ(spec->sensor.channel_at(1, 0), 2);
  EXPECT_EQ(spec->sensor.channel_at(0, 1), 0);
  EXPECT_EQ(spec->sensor.channel_at(3, 3), 1);
}

TEST(ColourSpec, WithoutPerChannelQeEveryChannelHasTheSensorsQe) {
  nlohmann::json camera = testing::colour_camera_json();
  camera["sensor"].erase("quantum_efficiency_rgb");
  camera["sensor"]["quantum_efficiency"] = 0.55;
  auto spec = parse_camera_spec(camera);
  ASSERT_TRUE(spec.ok()) << spec.error().message;
  EXPECT_EQ(spec->sensor.quantum_efficiency_rgb, (std::array<double, 3>{0.55, 0.55, 0.55}));
}

TEST(ColourSpec, AMonochromeSensorIsUnchanged) {
  auto spec = parse_camera_spec(testing::pinhole_camera_json());
  ASSERT_TRUE(spec.ok());
  EXPECT_FALSE(spec->sensor.is_colour());
  EXPECT_EQ(spec->lens.chromatic_focus_shift_mm, (std::array<double, 3>{0, 0, 0}));
}

struct BadColour {
  const char* description;
  const char* pointer;
  nlohmann::json value;
  bool mono;  // applied to the monochrome camera instead
  const char* expected_in_message;
};

class BadColourSpec : public ::testing::TestWithParam<BadColour> {};

TEST_P(BadColourSpec, IsRefusedNamingTheField) {
  const BadColour& bad = GetParam();
  nlohmann::json camera =
      bad.mono ? testing::pinhole_camera_json() : testing::colour_camera_json(64, 48);
  camera[nlohmann::json::json_pointer(bad.pointer)] = bad.value;
  auto spec = parse_camera_spec(camera);
  ASSERT_FALSE(spec.ok()) << bad.description;
  EXPECT_NE(spec.error().message.find(bad.expected_in_message), std::string::npos)
      << spec.error().message;
}

INSTANTIATE_TEST_SUITE_P(
    Fields, BadColourSpec,
    ::testing::Values(
        BadColour{"unknown order", "/sensor/cfa", "RGBG", false,
                  "camera.sensor.cfa = \"RGBG\" is not a Bayer order (RGGB, BGGR, GRBG, GBRG)"},
        BadColour{"order not a string", "/sensor/cfa", 1, false,
                  "camera.sensor.cfa must be a string"},
        BadColour{"odd width", "/sensor/width_px", 65, false, "must be even"},
        BadColour{"odd height", "/sensor/height_px", 47, false, "must be even"},
        BadColour{"two QE values",
                  "/sensor/quantum_efficiency_rgb",
                  {0.5, 0.5},
                  false,
                  "camera.sensor.quantum_efficiency_rgb must be an array of 3 numbers"},
        BadColour{"QE above 1",
                  "/sensor/quantum_efficiency_rgb",
                  {0.5, 1.5, 0.5},
                  false,
                  "camera.sensor.quantum_efficiency_rgb[1] = 1.5 must be a number in [0, 1]"},
        BadColour{"a blind channel",
                  "/sensor/quantum_efficiency_rgb",
                  {0.5, 0.5, 0.0},
                  false,
                  "quantum_efficiency_rgb[2] = 0"},
        BadColour{"QE per channel on a mono sensor",
                  "/sensor/quantum_efficiency_rgb",
                  {0.5, 0.5, 0.5},
                  true,
                  "needs a colour sensor (camera.sensor.cfa)"},
        BadColour{"focus shift on a mono sensor",
                  "/lens/chromatic_focus_shift_mm",
                  {0.01, 0, 0},
                  true,
                  "camera.lens.chromatic_focus_shift_mm needs a colour sensor"},
        BadColour{"focus shift beyond a tenth of f",
                  "/lens/chromatic_focus_shift_mm",
                  {0.9, 0, 0},
                  false,
                  "camera.lens.chromatic_focus_shift_mm[0] = 0.9 must be a number in [-0.8, 0.8]"},
        BadColour{"focus shift of two channels",
                  "/lens/chromatic_focus_shift_mm",
                  {0.01, 0},
                  false,
                  "must be an array of 3 numbers"},
        BadColour{"lateral colour on a mono sensor",
                  "/lens/lateral_colour_px",
                  {0.5, 0, 0},
                  true,
                  "camera.lens.lateral_colour_px needs a colour sensor"},
        BadColour{"lateral colour beyond 20 px",
                  "/lens/lateral_colour_px",
                  {0, 0, -25},
                  false,
                  "camera.lens.lateral_colour_px[2] = -25 must be a number in [-20, 20]"},
        BadColour{"JPEG quality 0", "/isp/jpeg_quality", 0, false,
                  "camera.isp.jpeg_quality = 0 is out of range [1, 100]"},
        BadColour{"JPEG quality 101", "/isp/jpeg_quality", 101, true, "[1, 100]"}),
    [](const auto& info) {
      std::string name = info.param.description;
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

TEST(ColourSpec, ReflectancesAreGreyOrRgbAndAMonoSensorSeesTheirLuminance) {
  nlohmann::json scene = testing::uniform_scene_json();
  scene["background_reflectance"] = {0.1, 0.2, 0.3};
  scene["targets"][0]["light_reflectance"] = {0.8, 0.5, 0.2};
  scene["targets"][0]["dark_reflectance"] = 0.05;
  auto spec = parse_scene_spec(scene);
  ASSERT_TRUE(spec.ok()) << spec.error().message;
  const TargetSpec& t = spec->targets[0];
  EXPECT_EQ(t.light.rgb, (std::array<double, 3>{0.8, 0.5, 0.2}));
  EXPECT_DOUBLE_EQ(t.light.grey, 0.2126 * 0.8 + 0.7152 * 0.5 + 0.0722 * 0.2);
  EXPECT_DOUBLE_EQ(t.light_reflectance, t.light.grey);
  EXPECT_EQ(t.dark.rgb, (std::array<double, 3>{0.05, 0.05, 0.05}));
  EXPECT_DOUBLE_EQ(t.dark_reflectance, 0.05);
  EXPECT_TRUE(t.dark.is_grey());
  EXPECT_FALSE(t.light.is_grey());
  EXPECT_DOUBLE_EQ(spec->background.grey, 0.2126 * 0.1 + 0.7152 * 0.2 + 0.0722 * 0.3);
}

TEST(ColourSpec, BadReflectancesNameTheTargetAndTheChannel) {
  nlohmann::json scene = testing::uniform_scene_json();
  scene["targets"][0]["light_reflectance"] = {0.8, 1.2, 0.2};
  auto spec = parse_scene_spec(scene);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("scene.targets[0].light_reflectance[1] = 1.2 must be a "
                                      "number in [0, 1]"),
            std::string::npos)
      << spec.error().message;

  scene["targets"][0]["light_reflectance"] = {0.8, 0.2};
  spec = parse_scene_spec(scene);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("must be an array of 3 numbers"), std::string::npos)
      << spec.error().message;

  scene["targets"][0]["light_reflectance"] = "red";
  spec = parse_scene_spec(scene);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("must be a reflectance in [0, 1] or [r, g, b]"),
            std::string::npos)
      << spec.error().message;

  scene = testing::uniform_scene_json();
  scene["background_reflectance"] = -0.1;
  spec = parse_scene_spec(scene);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("scene.background_reflectance"), std::string::npos)
      << spec.error().message;
}

}  // namespace
}  // namespace camlab::mock
