#include "mock_device/spec/rig_spec.h"

#include <cmath>

#include "mock_device/spec/json_fields.h"
#include "mock_device/spec/mrcal_api.h"

namespace camlab::mock {

namespace {

constexpr int kMaxRigCameras = 8;

// A spec given inline or as a path relative to the rig file.
Result<nlohmann::json> inline_or_file(const nlohmann::json& value, const std::string& path,
                                      const std::filesystem::path& base_dir) {
  if (value.is_object()) return value;
  if (!value.is_string())
    return make_error("invalid_argument", path + " must be a spec object or a file path");
  std::filesystem::path file = value.get<std::string>();
  if (file.is_relative()) file = base_dir / file;
  auto json = read_json_file(file);
  if (!json) return make_error(json.error().code, path + ": " + json.error().message);
  return json;
}

}  // namespace

RtCamTarget compose_rt(const RtCamTarget& rt_a_b, const RtCamTarget& rt_b_c) {
  RtCamTarget rt_a_c{};
  mrcal_compose_rt(rt_a_c.data(), nullptr, nullptr, nullptr, nullptr, rt_a_b.data(), rt_b_c.data());
  return rt_a_c;
}

SceneSpec scene_seen_from(const SceneSpec& scene_in_ref, const RtCamTarget& rt_cam_ref) {
  SceneSpec scene = scene_in_ref;
  for (size_t k = 0; k < scene.targets.size(); ++k) {
    TargetSpec& target = scene.targets[k];
    nlohmann::json poses = nlohmann::json::array();
    for (RtCamTarget& pose : target.poses) {
      pose = compose_rt(rt_cam_ref, pose);
      poses.push_back(pose);
    }
    // The source says what the camera saw: each target's poses, composed, as 6-vectors.
    if (scene.source.contains("targets") && k < scene.source["targets"].size()) {
      nlohmann::json& source = scene.source["targets"][k];
      source.erase("pose");
      source.erase("poses");
      if (poses.size() == 1)
        source["pose"] = poses[0];
      else
        source["poses"] = poses;
    }
  }
  scene.source["rig_rt_cam_ref"] = rt_cam_ref;
  return scene;
}

Result<RigSpec> parse_rig_spec(const nlohmann::json& json, const std::filesystem::path& base_dir) {
  if (!json.is_object()) return make_error("invalid_argument", "rig must be a JSON object");
  JsonFields f(json, "rig");
  RigSpec rig;
  CAMLAB_ASSIGN(rig.name, f.string("name", std::string("camlab virtual rig")));
  CAMLAB_ASSIGN(rig.view_every_frames, f.integer("view_every_frames", 0, 100000, 0));
  if (!f.has("scene")) return make_error("invalid_argument", "rig.scene is required");
  nlohmann::json scene_json;
  CAMLAB_ASSIGN(scene_json, inline_or_file(json.at("scene"), "rig.scene", base_dir));
  auto scene = parse_scene_spec(scene_json);
  if (!scene) return make_error(scene.error().code, "rig.scene: " + scene.error().message);
  rig.scene = std::move(*scene);
  if (!f.has("cameras") || !json.at("cameras").is_array() || json.at("cameras").size() < 2 ||
      json.at("cameras").size() > kMaxRigCameras)
    return make_error("invalid_argument", "rig.cameras must be an array of 2 to " +
                                              std::to_string(kMaxRigCameras) + " cameras");
  const auto& cameras = json.at("cameras");
  for (size_t i = 0; i < cameras.size(); ++i) {
    const std::string path = "rig.cameras[" + std::to_string(i) + "]";
    JsonFields c(cameras[i], path);
    if (!cameras[i].is_object() || !c.has("camera") || !c.has("rt_cam_ref"))
      return make_error("invalid_argument", path + " must be an object with camera and rt_cam_ref");
    RigCameraSpec member;
    CAMLAB_ASSIGN(member.name, c.string("name", "camera-" + std::to_string(i)));
    nlohmann::json camera_json;
    CAMLAB_ASSIGN(camera_json, inline_or_file(cameras[i].at("camera"), path + ".camera", base_dir));
    auto camera = parse_camera_spec(camera_json);
    if (!camera)
      return make_error(camera.error().code, path + ".camera: " + camera.error().message);
    member.camera = std::move(*camera);
    std::vector<double> rt;
    CAMLAB_ASSIGN(rt, c.numbers("rt_cam_ref", 6, 6, -1e3, 1e3));
    if (std::hypot(rt[0], rt[1], rt[2]) > M_PI + 1e-9)
      return make_error("out_of_range",
                        path + ".rt_cam_ref: a rotation vector longer than pi rad (180 deg)");
    std::copy(rt.begin(), rt.end(), member.rt_cam_ref.begin());
    CAMLAB_ASSIGN(member.trigger_offset_us, c.number("trigger_offset_us", -1e5, 1e5, 0.0));
    rig.cameras.push_back(std::move(member));
  }
  return rig;
}

Result<RigSpec> load_rig_spec(const std::filesystem::path& path) {
  auto json = read_json_file(path);
  if (!json) return json.error();
  auto rig = parse_rig_spec(*json, path.parent_path());
  if (!rig) return make_error(rig.error().code, path.string() + ": " + rig.error().message);
  return rig;
}

}  // namespace camlab::mock
