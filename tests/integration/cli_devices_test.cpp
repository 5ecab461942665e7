// `camlab devices` end to end: with the in-process virtual camera, the listing carries
// its formats and its controls with the ranges of its camera spec.
#include <gtest/gtest.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using camlab::testing::run_cli;
const std::filesystem::path kExamples =
    std::filesystem::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";

TEST(CliDevices, ListsTheVirtualCameraWithItsControlsAndRanges) {
  auto run = run_cli("devices --json --virtual " + (kExamples / "camera_640x480.json").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto cameras = nlohmann::json::parse(run.out);
  ASSERT_GE(cameras.size(), 1u);
  const auto& camera = cameras.back();
  EXPECT_EQ(camera["driver"], "camlab-vcam");
  EXPECT_EQ(camera["transport"], "in-process virtual camera");
  EXPECT_FALSE(camera.contains("errors")) << camera["errors"].dump();
  ASSERT_EQ(camera["formats"].size(), 3u);
  EXPECT_EQ(camera["formats"][0]["sizes"][0]["width_px"], 640);
  bool found_exposure = false;
  for (const auto& c : camera["controls"]) {
    if (c["name"] != "exposure_time_absolute") continue;
    found_exposure = true;
    EXPECT_EQ(c["min"], 1);
    EXPECT_EQ(c["max"], 333);  // the spec's, capped by the 33.3 ms frame interval
    EXPECT_EQ(c["current"], 50);
    EXPECT_EQ(c["unit"], "100 us");
  }
  EXPECT_TRUE(found_exposure);
}

TEST(CliDevices, ABrokenVirtualSpecIsASpecificError) {
  auto run = run_cli("devices --virtual " + (kExamples / "scene_slanted_edges.json").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("camera.sensor"), std::string::npos) << run.err;
}

}  // namespace
