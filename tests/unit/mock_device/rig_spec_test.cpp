// Rig specs: each camera sees the scene through its pose (checked against the pose applied
// by hand, with OpenCV's Rodrigues), and malformed rigs are refused naming the field.
#include "mock_device/spec/rig_spec.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "test_specs.h"

namespace camlab::mock {
namespace {
namespace rig_spec_test {

cv::Vec3d transform_point(const RtCamTarget& rt, const cv::Vec3d& p) {
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(rt[0], rt[1], rt[2]), r);
  return r * p + cv::Vec3d(rt[3], rt[4], rt[5]);
}

nlohmann::json two_camera_rig(const nlohmann::json& rt_second) {
  return {{"scene", testing::uniform_scene_json(1.5, 0.5)},
          {"cameras",
           {{{"name", "a"},
             {"camera", testing::pinhole_camera_json()},
             {"rt_cam_ref", {0, 0, 0, 0, 0, 0}}},
            {{"camera", testing::pinhole_camera_json()},
             {"rt_cam_ref", rt_second},
             {"trigger_offset_us", 250}}}}};
}

TEST(RigSpec, EachCameraSeesTheTargetsThroughItsPose) {
  const RtCamTarget rt_cam_ref = {0.1, -0.3, 0.05, -0.12, 0.01, 0.02};
  auto rig = parse_rig_spec(two_camera_rig(rt_cam_ref), ".");
  ASSERT_TRUE(rig.ok()) << rig.error().message;
  ASSERT_EQ(rig->cameras.size(), 2u);
  EXPECT_EQ(rig->cameras[0].name, "a");
  EXPECT_EQ(rig->cameras[1].name, "camera-1");
  EXPECT_DOUBLE_EQ(rig->cameras[1].trigger_offset_us, 250);
  const SceneSpec seen = scene_seen_from(rig->scene, rt_cam_ref);
  ASSERT_EQ(seen.targets.size(), rig->scene.targets.size());
  const RtCamTarget& in_ref = rig->scene.targets[0].poses[0];
  const RtCamTarget& in_cam = seen.targets[0].poses[0];
  // A point of the target, through the composed pose and through the two poses in turn.
  for (const cv::Vec3d& p : {cv::Vec3d(0, 0, 0), cv::Vec3d(0.3, -0.2, 0), cv::Vec3d(-1, 2, 0)}) {
    const cv::Vec3d direct = transform_point(in_cam, p),
                    in_turn = transform_point(rt_cam_ref, transform_point(in_ref, p));
    EXPECT_LT(cv::norm(direct - in_turn), 1e-12) << p[0] << " " << p[1];
  }
  // The scene JSON says what this camera saw.
  EXPECT_EQ(seen.source["targets"][0]["pose"].get<std::vector<double>>(),
            std::vector<double>(in_cam.begin(), in_cam.end()));
  EXPECT_EQ(seen.source["rig_rt_cam_ref"].get<std::vector<double>>(),
            std::vector<double>(rt_cam_ref.begin(), rt_cam_ref.end()));
}

TEST(RigSpec, MalformedRigsAreRefusedNamingTheField) {
  auto one = two_camera_rig({0, 0, 0, 0, 0, 0});
  one["cameras"].erase(1);
  auto refused = parse_rig_spec(one, ".");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("2 to 8 cameras"), std::string::npos);
  refused = parse_rig_spec(two_camera_rig({0, 0, 0, 0.1}), ".");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("rig.cameras[1].rt_cam_ref"), std::string::npos)
      << refused.error().message;
  refused = parse_rig_spec(two_camera_rig({4, 0, 0, 0, 0, 0}), ".");
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, "out_of_range") << refused.error().message;
  auto bad_camera = two_camera_rig({0, 0, 0, 0, 0, 0});
  bad_camera["cameras"][1]["camera"] = "no-such-camera.json";
  refused = parse_rig_spec(bad_camera, "/nonexistent");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("rig.cameras[1].camera"), std::string::npos)
      << refused.error().message;
  auto late = two_camera_rig({0, 0, 0, 0, 0, 0});
  late["cameras"][1]["trigger_offset_us"] = 2e5;
  refused = parse_rig_spec(late, ".");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("trigger_offset_us"), std::string::npos);
}

}  // namespace rig_spec_test
}  // namespace
}  // namespace camlab::mock
