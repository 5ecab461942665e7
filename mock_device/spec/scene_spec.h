// The virtual camera's scene: planar targets with poses, under uniform illumination,
// read from JSON (docs/virtual-camera.md documents every field with its unit).
//
// Target coordinates: x right, y down, in the target's plane z = 0, in metres. A pose is
// mrcal's rt_cam_target (rotation vector in radians, translation in metres) mapping a
// target point into the camera frame (x right, y down, z forward along the optical axis).
// A chessboard's and a ChArUco board's origin is its first inner corner (mrcal's
// convention); every other target's origin is its centre.
//
// A target may list several poses: the scene then has that many views (a calibration set
// is one scene with many views of one board).
//
// Reentrant: plain values, validated once in parse_scene_spec.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"

namespace camlab::mock {

enum class TargetType { kChessboard, kCharuco, kSlantedEdge, kBars, kTexture, kUniform };

const char* target_type_name(TargetType type);

using RtCamTarget = std::array<double, 6>;  // r (rad, rotation vector), t (m)

// A Lambertian reflectance (0..1), grey or per colour channel. A spec gives a number (grey:
// every channel the same) or [r, g, b]; a monochrome sensor sees `grey`, which for a
// colour reflectance is its Rec. 709 luminance 0.2126 r + 0.7152 g + 0.0722 b (the
// photopic response a bare silicon sensor with a luminance filter approximates).
struct Reflectance {
  double grey = 0;
  std::array<double, 3> rgb = {0, 0, 0};  // R, G, B

  static Reflectance uniform(double value) { return {value, {value, value, value}}; }
  bool is_grey() const { return rgb[0] == grey && rgb[1] == grey && rgb[2] == grey; }
};

struct TargetSpec {
  std::string name;
  TargetType type = TargetType::kUniform;
  std::vector<RtCamTarget> poses;  // one, or one per view

  // Lambertian reflectances of the dark and light parts (0..1): what a monochrome sensor
  // sees, and per channel what a colour one sees.
  double dark_reflectance = 0.05;
  double light_reflectance = 0.85;
  Reflectance dark = Reflectance::uniform(0.05);
  Reflectance light = Reflectance::uniform(0.85);

  // Chessboard and ChArUco: inner corners cols x rows, square size, and a light quiet
  // zone around the outer squares (in squares) so detectors find the outer corners.
  int corners_cols = 0;
  int corners_rows = 0;
  double square_m = 0;
  double margin_squares = 1.0;

  // Chessboard only: the three circle markers of OpenCV 4.6's findChessboardCornersSB
  // (CALIB_CB_MARKER), which name the corners of a board cut by the frame. Square (a, b)
  // (a = 0 .. corners_cols across, b = 0 .. corners_rows down; dark when a + b is even)
  // spans target x in [(a - 1), a] x square_m. The marker squares are the light square
  // (a, b) = marker_square() and the dark squares above it, (a, b - 1), and right of it,
  // (a + 1, b); each holds a disc of radius kMarkerRadiusSquares x square_m at its centre
  // in the other colour (OpenCV's gen_pattern.py radon_checkerboard layout; OpenCV 4.6
  // finds the markers only in this colouring).
  bool markers = false;
  static constexpr double kMarkerRadiusSquares = 0.17;
  // The light marker square (a, b): the board's middle square, moved one left when that
  // one is dark.
  std::array<int, 2> marker_square() const {
    int a = (corners_cols + 1) / 2;
    const int b = (corners_rows + 1) / 2;
    if ((a + b) % 2 == 0) --a;
    return {a, b};
  }
  // Whether target point (x, y) (m) lies in a marker disc.
  bool in_marker(double x_m, double y_m) const;

  // ChArUco (OpenCV 4.6's cv::aruco::CharucoBoard layout): (corners_cols + 1) x
  // (corners_rows + 1) squares, the top-left one dark; each light square holds an ArUco
  // marker of side marker_m (< square_m) at its centre, marker ids 0, 1, ... in row-major
  // order over the light squares; dictionary names cv::aruco's predefined dictionary
  // (image/aruco_dictionary.h). Inner corner (i, j) has the ChArUco id j * corners_cols + i.
  double marker_m = 0;
  std::string dictionary;

  // Whether the target is a board of squares (chessboard or ChArUco).
  bool has_squares() const {
    return type == TargetType::kChessboard || type == TargetType::kCharuco;
  }

  // Every other target: its extent, centred on its origin.
  double width_m = 0;
  double height_m = 0;

  // Slanted edge: the edge passes through the origin at angle_deg from the target's
  // y axis (clockwise in the image); dark on the -x side, light on the +x side.
  double angle_deg = 5.0;

  // Bars: `bar_count` dark vertical bars of bar_width_m with bar_gap_m of light between.
  double bar_width_m = 0;
  double bar_gap_m = 0;
  int bar_count = 0;

  // Texture: band-limited random reflectance with features of about feature_m.
  double feature_m = 0;
  uint64_t texture_seed = 1;

  // Extent in target coordinates (m): [x_min, x_max] x [y_min, y_max].
  double x_min_m() const;
  double x_max_m() const;
  double y_min_m() const;
  double y_max_m() const;
};

struct SceneSpec {
  std::string name;
  double illuminance_lux = 500;          // uniform illumination of every target
  double background_reflectance = 0.18;  // what rays that hit no target see (at infinity)
  Reflectance background = Reflectance::uniform(0.18);
  std::vector<TargetSpec> targets;
  int view_count = 1;  // max number of poses over the targets
  nlohmann::json source;

  // The pose of a target in a view (a single-pose target is static across views).
  const RtCamTarget& pose(const TargetSpec& target, int view) const {
    return target.poses.size() == 1 ? target.poses[0] : target.poses[view];
  }
};

Result<SceneSpec> parse_scene_spec(const nlohmann::json& json);

// One pose as a scene spec writes it: [rx, ry, rz, tx, ty, tz] (rt_cam_target),
// {"rt_cam_target": [...]}, or {"position_m": [x, y, z], "rotation_deg": [rx, ry, rz]} (a
// rotation vector in degrees). `path` names it in errors. Errors: "invalid_argument",
// "out_of_range" (the origin not in front of the camera).
Result<RtCamTarget> parse_target_pose(const nlohmann::json& json, const std::string& path);
Result<SceneSpec> load_scene_spec(const std::filesystem::path& path);

}  // namespace camlab::mock
