// Spec files: the examples load, and every kind of bad input is refused with a message
// naming the field, its value and what is allowed.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "mock_device/spec/rig_spec.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace specs_test {

const std::filesystem::path kExamples =
    std::filesystem::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";

TEST(Specs, EveryExampleLoadsAndRenders) {
  int cameras = 0, scenes = 0, rigs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kExamples)) {
    const auto name = entry.path().filename().string();
    if (name.rfind("camera_", 0) == 0) {
      auto spec = load_camera_spec(entry.path());
      EXPECT_TRUE(spec.ok()) << name << ": " << spec.error().message;
      ++cameras;
    } else if (name.rfind("scene_", 0) == 0) {
      auto spec = load_scene_spec(entry.path());
      EXPECT_TRUE(spec.ok()) << name << ": " << spec.error().message;
      ++scenes;
    } else if (name.rfind("rig_", 0) == 0) {
      auto spec = load_rig_spec(entry.path());
      EXPECT_TRUE(spec.ok()) << name << ": " << spec.error().message;
      ++rigs;
    }
  }
  EXPECT_GE(cameras, 2);
  EXPECT_GE(scenes, 3);
  EXPECT_GE(rigs, 1);
}

struct BadCamera {
  const char* description;
  nlohmann::json::json_pointer field;
  nlohmann::json value;
  const char* expected_in_message;
};

class BadCameraSpec : public ::testing::TestWithParam<BadCamera> {};

TEST_P(BadCameraSpec, IsRefusedNamingTheField) {
  nlohmann::json camera = testing::pinhole_camera_json();
  camera[GetParam().field] = GetParam().value;
  auto spec = parse_camera_spec(camera);
  ASSERT_FALSE(spec.ok()) << GetParam().description;
  EXPECT_NE(spec.error().message.find(GetParam().expected_in_message), std::string::npos)
      << spec.error().message;
}

INSTANTIATE_TEST_SUITE_P(
    Fields, BadCameraSpec,
    ::testing::Values(
        BadCamera{"negative pitch", "/sensor/pixel_pitch_um"_json_pointer, -3.0,
                  "camera.sensor.pixel_pitch_um"},
        BadCamera{"zero pitch", "/sensor/pixel_pitch_um"_json_pointer, 0.0, "(0, 100]"},
        BadCamera{"string width", "/sensor/width_px"_json_pointer, "640", "must be an integer"},
        BadCamera{"bit depth 20", "/sensor/bit_depth"_json_pointer, 20, "[8, 16]"},
        BadCamera{"unknown model", "/lens/model"_json_pointer, "LENSMODEL_FOO",
                  "not an mrcal lens model"},
        BadCamera{"wrong distortion count", "/lens/model"_json_pointer, "LENSMODEL_OPENCV8",
                  "camera.lens.distortion is required"},
        BadCamera{"negative focal", "/lens/focal_mm"_json_pointer, -8.0, "camera.lens.focal_mm"},
        BadCamera{"exposure past the frame interval",
                  "/controls/exposure_time_absolute/max"_json_pointer, 5000,
                  "exceeds the frame interval"},
        BadCamera{"iris not falling",
                  "/lens/iris"_json_pointer,
                  {{"f_numbers", {2.0, 4.0}}},
                  "must fall"}),
    [](const auto& info) {
      std::string name = info.param.description;
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

TEST(Specs, DistortionOfTheWrongLengthIsRefused) {
  nlohmann::json camera = testing::pinhole_camera_json();
  camera["lens"]["model"] = "LENSMODEL_OPENCV4";
  camera["lens"]["distortion"] = {0.1, 0.2};
  auto spec = parse_camera_spec(camera);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("array of 4 numbers"), std::string::npos)
      << spec.error().message;
}

TEST(Specs, SceneErrorsNameTheTarget) {
  nlohmann::json scene = testing::uniform_scene_json();
  scene["targets"][0]["pose"] = {{"position_m", {0.0, 0.0, -1.0}}};
  auto spec = parse_scene_spec(scene);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("scene.targets[0].pose"), std::string::npos)
      << spec.error().message;
  EXPECT_NE(spec.error().message.find("in front of the camera"), std::string::npos);

  scene = testing::uniform_scene_json();
  scene["targets"][0]["type"] = "teapot";
  spec = parse_scene_spec(scene);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("teapot"), std::string::npos);

  scene = testing::uniform_scene_json();
  scene["targets"].push_back(scene["targets"][0]);
  scene["targets"][0].erase("pose");
  scene["targets"][0]["poses"] = {{{"position_m", {0, 0, 1}}}, {{"position_m", {0, 0, 2}}}};
  scene["targets"][1].erase("pose");
  scene["targets"][1]["poses"] = {
      {{"position_m", {0, 0, 1}}}, {{"position_m", {0, 0, 2}}}, {{"position_m", {0, 0, 3}}}};
  spec = parse_scene_spec(scene);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("every target must have 1 or"), std::string::npos);
}

TEST(Specs, MalformedJsonFileIsRefusedWithItsPath) {
  const auto path = std::filesystem::temp_directory_path() / "camlab_bad_camera.json";
  { std::ofstream(path) << "{ \"sensor\": { \"width_px\": 640, "; }
  auto spec = load_camera_spec(path);
  ASSERT_FALSE(spec.ok());
  EXPECT_EQ(spec.error().code, "bad_json");
  EXPECT_NE(spec.error().message.find(path.string()), std::string::npos);
  std::filesystem::remove(path);
  EXPECT_FALSE(load_camera_spec("/nonexistent/camera.json").ok());
}

TEST(Specs, FocusBreathingScalesTheFocalLengthInPixels) {
  auto spec = parse_camera_spec(testing::pinhole_camera_json());
  ASSERT_TRUE(spec.ok());
  // fx = lens-to-sensor distance / pitch: 8 mm / 4 um = 2000 px at infinity focus.
  EXPECT_DOUBLE_EQ(intrinsics_at(*spec, 8.0)[0], 2000.0);
  EXPECT_DOUBLE_EQ(intrinsics_at(*spec, 8.2)[0], 2050.0);
  EXPECT_DOUBLE_EQ(intrinsics_at(*spec, 8.0)[2], 127.5);  // (256 - 1) / 2
}

}  // namespace specs_test
}  // namespace
}  // namespace camlab::mock
