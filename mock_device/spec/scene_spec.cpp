#include "mock_device/spec/scene_spec.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "image/aruco_dictionary.h"
#include "mock_device/spec/json_fields.h"

namespace camlab::mock {

const char* target_type_name(TargetType type) {
  switch (type) {
    case TargetType::kChessboard:
      return "chessboard";
    case TargetType::kCharuco:
      return "charuco";
    case TargetType::kSlantedEdge:
      return "slanted_edge";
    case TargetType::kBars:
      return "bars";
    case TargetType::kTexture:
      return "texture";
    case TargetType::kUniform:
      return "uniform";
  }
  return "unknown";
}

bool TargetSpec::in_marker(double x_m, double y_m) const {
  if (!markers) return false;
  const auto [a, b] = marker_square();
  const double r = kMarkerRadiusSquares * square_m;
  // Square (a, b)'s centre is at ((a - 0.5), (b - 0.5)) x square_m.
  for (const auto& [sa, sb] : {std::array{a, b}, std::array{a, b - 1}, std::array{a + 1, b}}) {
    const double dx = x_m - (sa - 0.5) * square_m, dy = y_m - (sb - 0.5) * square_m;
    if (dx * dx + dy * dy < r * r) return true;
  }
  return false;
}

double TargetSpec::x_min_m() const {
  return has_squares() ? -(1 + margin_squares) * square_m : -width_m / 2;
}
double TargetSpec::x_max_m() const {
  return has_squares() ? (corners_cols + margin_squares) * square_m : width_m / 2;
}
double TargetSpec::y_min_m() const {
  return has_squares() ? -(1 + margin_squares) * square_m : -height_m / 2;
}
double TargetSpec::y_max_m() const {
  return has_squares() ? (corners_rows + margin_squares) * square_m : height_m / 2;
}

Result<RtCamTarget> parse_target_pose(const nlohmann::json& json, const std::string& path) {
  std::vector<double> values;
  if (json.is_array()) {
    nlohmann::json wrapper = {{"rt_cam_target", json}};
    JsonFields f(wrapper, path);
    CAMLAB_ASSIGN(values, f.numbers("rt_cam_target", 6, 6, -1e6, 1e6));
  } else if (json.is_object()) {
    JsonFields f(json, path);
    if (f.has("rt_cam_target")) {
      CAMLAB_ASSIGN(values, f.numbers("rt_cam_target", 6, 6, -1e6, 1e6));
    } else {
      std::vector<double> position, rotation = {0, 0, 0};
      CAMLAB_ASSIGN(position, f.numbers("position_m", 3, 3, -1e6, 1e6));
      if (f.has("rotation_deg"))
        CAMLAB_ASSIGN(rotation, f.numbers("rotation_deg", 3, 3, -720, 720));
      const double to_rad = std::numbers::pi / 180.0;
      values = {rotation[0] * to_rad, rotation[1] * to_rad, rotation[2] * to_rad,
                position[0],          position[1],          position[2]};
    }
  } else {
    return make_error("invalid_argument",
                      path + " must be an rt_cam_target array or a pose object");
  }
  if (values[5] <= 0)
    return make_error("out_of_range", path +
                                          ": the target origin must be in front of the "
                                          "camera (z = " +
                                          std::to_string(values[5]) + " m)");
  RtCamTarget rt;
  std::copy(values.begin(), values.end(), rt.begin());
  return rt;
}

namespace {

// A reflectance: a number in [0, 1] (grey), or [r, g, b] each in [0, 1].
Result<Reflectance> parse_reflectance(const JsonFields& f, const char* key, double fallback) {
  if (f.has(key) && f.json().at(key).is_array()) {
    std::vector<double> rgb;
    CAMLAB_ASSIGN(rgb, f.numbers(key, 3, 3, 0, 1));
    Reflectance r;
    r.rgb = {rgb[0], rgb[1], rgb[2]};
    r.grey = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    return r;
  }
  if (f.has(key) && !f.json().at(key).is_number())
    return make_error("invalid_argument",
                      f.path_of(key) + " must be a reflectance in [0, 1] or [r, g, b], not " +
                          f.json().at(key).dump());
  double grey = 0;
  CAMLAB_ASSIGN(grey, f.number(key, 0, 1, fallback));
  return Reflectance::uniform(grey);
}

// A ChArUco board: "squares": [cols, rows], "square_m", "marker_m", "dictionary",
// "margin_squares". Checked against what OpenCV's CharucoBoard can be: a marker smaller
// than its square, a known dictionary, and one marker of it for every light square.
Status parse_charuco(const JsonFields& f, TargetSpec* t) {
  std::vector<double> squares;
  CAMLAB_ASSIGN(squares, f.numbers("squares", 2, 2, 3, 201));
  const int cols = static_cast<int>(squares[0]), rows = static_cast<int>(squares[1]);
  if (cols != squares[0] || rows != squares[1])
    return make_error("invalid_argument", f.path_of("squares") + " must be two integers");
  t->corners_cols = cols - 1;
  t->corners_rows = rows - 1;
  CAMLAB_ASSIGN(t->square_m, f.number("square_m", 0, 10, std::nullopt, true));
  CAMLAB_ASSIGN(t->marker_m, f.number("marker_m", 0, 10, std::nullopt, true));
  if (!(t->marker_m < t->square_m))
    return make_error("out_of_range",
                      f.path_of("marker_m") + " = " + f.json().at("marker_m").dump() +
                          " m must be smaller than square_m = " + f.json().at("square_m").dump() +
                          " m (a marker sits inside a light square)");
  CAMLAB_ASSIGN(t->margin_squares, f.number("margin_squares", 0, 100, 1.0));
  CAMLAB_ASSIGN(t->dictionary, f.string("dictionary"));
  image::ArucoDictionary dictionary;
  if (auto d = image::find_aruco_dictionary(t->dictionary); d.ok())
    dictionary = *d;
  else
    return d.error().with_context(f.path_of("dictionary") + ": ");
  // The light squares hold the markers: half the squares, rounded down (the top-left
  // square is dark).
  const int markers = cols * rows / 2;
  if (markers > dictionary.marker_count)
    return make_error("out_of_range", f.path() + ": a " + std::to_string(cols) + "x" +
                                          std::to_string(rows) + "-square ChArUco board needs " +
                                          std::to_string(markers) + " markers; " + dictionary.name +
                                          " has " + std::to_string(dictionary.marker_count));
  return {};
}

Result<TargetSpec> parse_target(const JsonFields& f) {
  TargetSpec t;
  std::string type;
  CAMLAB_ASSIGN(type, f.string("type"));
  CAMLAB_ASSIGN(t.name, f.string("name", type));
  if (type == "chessboard")
    t.type = TargetType::kChessboard;
  else if (type == "charuco")
    t.type = TargetType::kCharuco;
  else if (type == "slanted_edge")
    t.type = TargetType::kSlantedEdge;
  else if (type == "bars")
    t.type = TargetType::kBars;
  else if (type == "texture")
    t.type = TargetType::kTexture;
  else if (type == "uniform")
    t.type = TargetType::kUniform;
  else
    return make_error("invalid_argument", f.path_of("type") + " = \"" + type +
                                              "\" is not one of chessboard, charuco, slanted_edge, "
                                              "bars, texture, uniform");

  CAMLAB_ASSIGN(t.dark, parse_reflectance(f, "dark_reflectance", 0.05));
  CAMLAB_ASSIGN(t.light, parse_reflectance(f, "light_reflectance", 0.85));
  t.dark_reflectance = t.dark.grey;
  t.light_reflectance = t.light.grey;

  if (t.type == TargetType::kChessboard) {
    std::vector<double> corners;
    CAMLAB_ASSIGN(corners, f.numbers("inner_corners", 2, 2, 2, 200));
    t.corners_cols = static_cast<int>(corners[0]);
    t.corners_rows = static_cast<int>(corners[1]);
    if (t.corners_cols != corners[0] || t.corners_rows != corners[1])
      return make_error("invalid_argument", f.path_of("inner_corners") + " must be two integers");
    CAMLAB_ASSIGN(t.square_m, f.number("square_m", 0, 10, std::nullopt, true));
    CAMLAB_ASSIGN(t.margin_squares, f.number("margin_squares", 0, 100, 1.0));
    CAMLAB_ASSIGN(t.markers, f.boolean("markers", false));
  } else if (t.type == TargetType::kCharuco) {
    if (Status s = parse_charuco(f, &t); !s) return s.error();
  } else {
    std::vector<double> size;
    CAMLAB_ASSIGN(size, f.numbers("size_m", 2, 2, 1e-6, 1e6));
    t.width_m = size[0];
    t.height_m = size[1];
  }
  if (t.type == TargetType::kSlantedEdge)
    CAMLAB_ASSIGN(t.angle_deg, f.number("angle_deg", -90, 90, 5.0));
  if (t.type == TargetType::kBars) {
    CAMLAB_ASSIGN(t.bar_width_m, f.number("bar_width_m", 0, 1e3, std::nullopt, true));
    CAMLAB_ASSIGN(t.bar_gap_m, f.number("bar_gap_m", 0, 1e3, t.bar_width_m, true));
    CAMLAB_ASSIGN(t.bar_count, f.integer("bar_count", 1, 10000, 5));
  }
  if (t.type == TargetType::kTexture) {
    CAMLAB_ASSIGN(t.feature_m, f.number("feature_m", 0, 1e3, std::nullopt, true));
    int seed = 1;
    CAMLAB_ASSIGN(seed, f.integer("seed", 0, 1 << 30, 1));
    t.texture_seed = static_cast<uint64_t>(seed);
    const double features = std::max(t.width_m, t.height_m) / t.feature_m;
    if (features > 4096)
      return make_error("out_of_range", f.path() +
                                            ": size_m / feature_m = " + std::to_string(features) +
                                            " features exceeds the texture limit of 4096");
  }

  if (f.has("pose") == f.has("poses"))
    return make_error("invalid_argument", f.path() + " needs exactly one of \"pose\" or \"poses\"");
  if (f.has("pose")) {
    RtCamTarget rt;
    CAMLAB_ASSIGN(rt, parse_target_pose(f.json().at("pose"), f.path_of("pose")));
    t.poses.push_back(rt);
  } else {
    const auto& poses = f.json().at("poses");
    if (!poses.is_array() || poses.empty() || poses.size() > 10000)
      return make_error("invalid_argument",
                        f.path_of("poses") + " must be a non-empty array (<= 10000)");
    for (size_t i = 0; i < poses.size(); ++i) {
      RtCamTarget rt;
      CAMLAB_ASSIGN(
          rt, parse_target_pose(poses[i], f.path_of("poses") + "[" + std::to_string(i) + "]"));
      t.poses.push_back(rt);
    }
  }
  return t;
}

}  // namespace

Result<SceneSpec> parse_scene_spec(const nlohmann::json& json) {
  if (!json.is_object()) return make_error("invalid_argument", "scene spec must be a JSON object");
  JsonFields root(json, "scene");
  SceneSpec scene;
  scene.source = json;
  CAMLAB_ASSIGN(scene.name, root.string("name", "scene"));
  CAMLAB_ASSIGN(scene.illuminance_lux, root.number("illuminance_lux", 0, 1e6, 500.0));
  CAMLAB_ASSIGN(scene.background, parse_reflectance(root, "background_reflectance", 0.18));
  scene.background_reflectance = scene.background.grey;
  if (!root.has("targets") || !json.at("targets").is_array())
    return make_error("invalid_argument", "scene.targets must be an array of targets");
  const auto& targets = json.at("targets");
  if (targets.size() > 64)
    return make_error("out_of_range", "scene.targets has " + std::to_string(targets.size()) +
                                          " targets; at most 64 are supported");
  for (size_t i = 0; i < targets.size(); ++i) {
    TargetSpec target;
    CAMLAB_ASSIGN(target,
                  parse_target(JsonFields(targets[i], "scene.targets[" + std::to_string(i) + "]")));
    scene.targets.push_back(std::move(target));
  }
  scene.view_count = 1;
  for (const auto& t : scene.targets)
    scene.view_count = std::max<int>(scene.view_count, t.poses.size());
  for (size_t i = 0; i < scene.targets.size(); ++i) {
    const auto n = scene.targets[i].poses.size();
    if (n != 1 && static_cast<int>(n) != scene.view_count)
      return make_error("invalid_argument", "scene.targets[" + std::to_string(i) + "].poses has " +
                                                std::to_string(n) +
                                                " poses; every target must have 1 or " +
                                                std::to_string(scene.view_count));
  }
  return scene;
}

Result<SceneSpec> load_scene_spec(const std::filesystem::path& path) {
  auto json = read_json_file(path);
  if (!json) return json.error();
  auto scene = parse_scene_spec(*json);
  if (!scene) return make_error(scene.error().code, path.string() + ": " + scene.error().message);
  return scene;
}

}  // namespace camlab::mock
