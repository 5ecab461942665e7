// The one default virtual camera (mock_device/spec/default_specs.h): it parses, and it has
// every control a capture plan may drive (iris and gain included), so camlabd's, `camlab
// vcam run`'s and `camlab devices --virtual`'s virtual cameras can do every capture kind.
#include "mock_device/spec/default_specs.h"

#include <gtest/gtest.h>

namespace camlab::mock {
namespace {

TEST(DefaultSpecs, TheDefaultCameraParsesWithIrisGainAndFocus) {
  auto camera = parse_camera_spec(default_camera_spec_json());
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  EXPECT_EQ(camera->sensor.width_px, 640);
  EXPECT_EQ(camera->sensor.height_px, 480);
  EXPECT_GE(camera->lens.iris.f_numbers.size(), 2u) << "aperture series need an iris";
  EXPECT_GT(camera->controls.gain.max, camera->controls.gain.min) << "brackets may step gain";
  EXPECT_GT(camera->lens.focus.position_max, camera->lens.focus.position_min)
      << "focus stacks need a motor";
  EXPECT_EQ(default_camera_spec().source, default_camera_spec_json());
}

TEST(DefaultSpecs, TheDefaultSceneParsesAndHasEdgesToMeasure) {
  auto scene = parse_scene_spec(default_scene_spec_json());
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->targets.size(), 3u);
  EXPECT_EQ(default_scene_spec().source, default_scene_spec_json());
}

}  // namespace
}  // namespace camlab::mock
