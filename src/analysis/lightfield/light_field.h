// A light field read for measurement: the views of a light-field folder
// (image/lightfield_folder.h) as signal above black, and the thin-lens geometry that
// turns a distance into the views' shifts (docs/physics.md, "Light fields").
//
// Geometry. With the sensor at z_s focused at s (q = 1/s, 0 at infinity), the ray from
// lens point o (m, on the lens) towards where a pixel's chief ray m meets the plane of
// focus reaches depth z at z m + o (1 - z q): the view through o sees a point X at
// m = X/z - o (1/z - q). So against the view through the lens centre a point at depth z
// lands, in the view through o, at a disparity of
//
//   d = -f_px o (1/z - q)  pixels,  f_px = z_s / pitch,
//
// linear in o (its slope gives the depth) and spanning over the aperture A the circle of
// confusion f_px A |1/z - q| = A |1 - z_s / z_i| / pitch (docs/physics.md). Refocusing at
// S (q_r = 1/S) moves each view by +f_px o (q_r - q) (it samples the view at
// -f_px o (q_r - q) from where the output pixel is) and magnifies by alpha = z_r / z_s,
// z_r = 1 / (1/f - q_r), the sensor distance that focuses at S.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "image/lightfield_folder.h"

namespace camlab::analysis::lightfield {

struct LightField {
  image::LightFieldDescription description;
  std::vector<cv::Mat> views;  // CV_32F, DN above black, one per description.views
  int bit_depth = 8;
  int black_level_dn = 0;
  nlohmann::json source;    // the folder manifest's source (the camera), passed on
  nlohmann::json settings;  // the views' settings (the first view's sidecar)
};

// Errors: those of LightFieldFolder::open and of reading the views; "unsupported" for
// views that are not mono and linear; "bad_frame" for views of different sizes.
Result<LightField> load_light_field(const std::filesystem::path& dir);

// The numbers refocusing and depth work with, from a light field's optics.
struct ViewGeometry {
  double f_px = 0;                 // z_s / pixel pitch: px per unit of x/z
  double inverse_focus_per_m = 0;  // q = 1/s of the capture (0 at infinity)
  double focal_mm = 0;
  double lens_to_sensor_mm = 0;
  double aperture_radius_m = 0;  // A / 2 = f / (2N)
  double cell_pitch_m = 0;       // the aperture grid's cell side (the larger of u, v)
  std::array<double, 2> principal_point_px{0, 0};
};
ViewGeometry view_geometry(const image::LightFieldDescription& description);

// The sensor distance (mm) that focuses at `focus_m` (1 / (1/f - 1/S)); errors:
// "out_of_range" for a distance that is not positive and finite or infinite (behind the
// lens), "no_real_image" for one at or inside the focal length, both naming the value and
// the allowed range.
Result<double> refocus_lens_to_sensor_mm(const ViewGeometry& g, double focus_m);

}  // namespace camlab::analysis::lightfield
