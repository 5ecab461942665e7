#include "mock_device/render/frame_truth.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "image/cameramodel_file.h"
#include "mock_device/render/field_focus.h"
#include "mock_device/spec/mrcal_api.h"
#include "optics/optics.h"

namespace camlab::mock {

namespace {

double coc_px_at_depth(const CameraSpec& camera, double f_number, double focus_mm,
                       double depth_mm) {
  auto coc = optics::circle_of_confusion_mm(camera.lens.focal_mm, f_number, focus_mm, depth_mm);
  // A point inside the focal length has no real image: report the aperture-sized blur
  // the lens would give at the focal length, never NaN.
  const double coc_mm = coc ? *coc : camera.lens.focal_mm / f_number;
  return coc_mm / (camera.sensor.pixel_pitch_um * 1e-3);
}

// Projects camera-frame points (m) through the model; nullopt-like flag when behind the
// camera or off the imager.
std::vector<nlohmann::json> project_points(const CameraSpec& camera,
                                           const std::vector<double>& intrinsics,
                                           const std::vector<std::array<double, 3>>& points,
                                           bool null_if_off_imager) {
  mrcal_lensmodel_t lensmodel;
  mrcal_lensmodel_from_name(&lensmodel, camera.lens.model.c_str());
  std::vector<mrcal_point3_t> p(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    p[i] = {.x = points[i][0], .y = points[i][1], .z = points[i][2]};
  std::vector<mrcal_point2_t> q(points.size());
  mrcal_project(q.data(), nullptr, nullptr, p.data(), static_cast<int>(p.size()), &lensmodel,
                intrinsics.data());
  std::vector<nlohmann::json> out;
  for (size_t i = 0; i < points.size(); ++i) {
    const bool in_front = points[i][2] > 0;
    const bool on_imager = q[i].x >= -0.5 && q[i].y >= -0.5 &&
                           q[i].x <= camera.sensor.width_px - 0.5 &&
                           q[i].y <= camera.sensor.height_px - 0.5;
    if (!in_front || !std::isfinite(q[i].x) || !std::isfinite(q[i].y) ||
        (null_if_off_imager && !on_imager))
      out.emplace_back(nullptr);
    else
      out.push_back({q[i].x, q[i].y});
  }
  return out;
}

}  // namespace

CocRange predicted_coc(const CameraSpec& camera, const TargetSurface& surface, double f_number,
                       double focus_distance_mm) {
  const TargetSpec& t = surface.spec();
  const double us[] = {t.x_min_m(), t.x_max_m(), t.x_min_m(), t.x_max_m()};
  const double vs[] = {t.y_min_m(), t.y_min_m(), t.y_max_m(), t.y_max_m()};
  CocRange range;
  range.at_origin_px =
      coc_px_at_depth(camera, f_number, focus_distance_mm, surface.to_camera(0, 0)[2] * 1e3);
  range.min_px = range.max_px = range.at_origin_px;
  for (int i = 0; i < 4; ++i) {
    const double depth_m = surface.to_camera(us[i], vs[i])[2];
    if (depth_m <= 0) continue;  // behind the lens: not imaged
    const double c = coc_px_at_depth(camera, f_number, focus_distance_mm, depth_m * 1e3);
    range.min_px = std::min(range.min_px, c);
    range.max_px = std::max(range.max_px, c);
  }
  // A plane that crosses the plane of focus is sharp somewhere on it.
  double z_min = 1e300, z_max = -1e300;
  for (int i = 0; i < 4; ++i) {
    const double z = surface.to_camera(us[i], vs[i])[2] * 1e3;
    z_min = std::min(z_min, z);
    z_max = std::max(z_max, z);
  }
  if (z_min <= focus_distance_mm && focus_distance_mm <= z_max) range.min_px = 0;
  return range;
}

CocRange predicted_coc(const ChannelOptics& optics, double pixel_pitch_um,
                       const TargetSurface& surface) {
  const TargetSpec& t = surface.spec();
  const double us[] = {t.x_min_m(), t.x_max_m(), t.x_min_m(), t.x_max_m()};
  const double vs[] = {t.y_min_m(), t.y_min_m(), t.y_max_m(), t.y_max_m()};
  const double pitch_mm = pixel_pitch_um * 1e-3;
  CocRange range;
  range.at_origin_px = optics.coc_mm(surface.to_camera(0, 0)[2] * 1e3) / pitch_mm;
  range.min_px = range.max_px = range.at_origin_px;
  double z_min = 1e300, z_max = -1e300;
  for (int i = 0; i < 4; ++i) {
    const double depth_mm = surface.to_camera(us[i], vs[i])[2] * 1e3;
    z_min = std::min(z_min, depth_mm);
    z_max = std::max(z_max, depth_mm);
    if (depth_mm <= 0) continue;  // behind the lens: not imaged
    const double c = optics.coc_mm(depth_mm) / pitch_mm;
    range.min_px = std::min(range.min_px, c);
    range.max_px = std::max(range.max_px, c);
  }
  // A plane that crosses the channel's plane of focus is sharp somewhere on it.
  const double s = optics.focus_distance_mm;
  if (s > 0 && z_min <= s && s <= z_max) range.min_px = 0;
  return range;
}

std::string truth_cameramodel_text(const CameraSpec& camera,
                                   const std::vector<double>& intrinsics) {
  image::CameraModelText model;
  model.lensmodel = camera.lens.model;
  model.intrinsics = intrinsics;
  model.imagersize = {static_cast<unsigned>(camera.sensor.width_px),
                      static_cast<unsigned>(camera.sensor.height_px)};
  model.comment = "camlab virtual camera truth: " + camera.name;
  return image::to_cameramodel_text(model);
}

namespace {

// Noise-free DN of a reflectance in a channel: black + electrons (clipped at the full
// well) x K x gain, clipped to the DN range; not rounded (a frame's mean over many
// pixels of one reflectance is this within the rounding's +-0.5 DN).
double expected_dn(const SensorSpec& sensor, double electrons, double gain) {
  const double max_dn = (1 << sensor.bit_depth) - 1;
  const double dn = sensor.black_level_dn + std::min(electrons, sensor.full_well_e) *
                                                sensor.conversion_gain_dn_per_e * gain;
  return std::clamp(dn, 0.0, max_dn);
}

// A target's blur with a tilted or curved focus surface (field_focus.h): at its origin,
// through the surface's offset at the origin's image point; min and max over the offsets
// the surface takes anywhere on the imager (every point of the target is imaged with one
// of them), 0 when some offset puts the target's plane of focus on it.
CocRange coc_on_focus_surface(const TruthInputs& in, const TargetSurface& surface, int channel) {
  const CameraSpec& camera = *in.camera;
  const FieldFocus field = *make_field_focus(camera, in.lens_to_sensor_mm);
  const double pitch_um = camera.sensor.pixel_pitch_um;
  double delta_lo, delta_hi;
  field.offset_range_mm(0, camera.sensor.width_px, 0, camera.sensor.height_px, &delta_lo,
                        &delta_hi);
  double delta_origin = 0;
  const auto origin = project_points(camera, in.intrinsics, {surface.to_camera(0, 0)}, false);
  if (!origin[0].is_null())
    delta_origin =
        field.offset_mm(origin[0][0].get<double>() + 0.5, origin[0][1].get<double>() + 0.5);
  CocRange range;
  range.min_px = INFINITY;
  range.max_px = 0;
  std::array<double, 2> focus_mm = {0, 0};
  int k = 0;
  for (double delta : {delta_origin, delta_lo, delta_hi}) {
    auto optics = channel_optics(camera, channel, in.f_number, in.lens_to_sensor_mm - delta);
    if (!optics) continue;
    const CocRange c = predicted_coc(*optics, pitch_um, surface);
    if (k == 0) range.at_origin_px = c.at_origin_px;
    range.min_px = std::min(range.min_px, c.min_px);
    range.max_px = std::max(range.max_px, c.max_px);
    if (k > 0) focus_mm[static_cast<size_t>(k - 1)] = optics->focus_distance_mm;
    ++k;
  }
  // The planes of focus between the extremes: finite and in front of the lens at both ends
  // (the offsets do not cross infinity), a target whose depths meet them is sharp there.
  const TargetSpec& t = surface.spec();
  double z_min = INFINITY, z_max = -INFINITY;
  for (double u : {t.x_min_m(), t.x_max_m()})
    for (double v : {t.y_min_m(), t.y_max_m()}) {
      const double z = surface.to_camera(u, v)[2] * 1e3;
      z_min = std::min(z_min, z);
      z_max = std::max(z_max, z);
    }
  const double s_lo = std::min(focus_mm[0], focus_mm[1]), s_hi = std::max(focus_mm[0], focus_mm[1]);
  if (s_lo > 0 && std::isfinite(s_hi) && z_min <= s_hi && s_lo <= z_max) range.min_px = 0;
  if (!std::isfinite(range.min_px)) range.min_px = 0;
  return range;
}

// truth.channels: for each colour its optics, its predicted CoC of each target, and the
// expected DN of each target's dark and light parts and of the background.
nlohmann::json channels_truth(const TruthInputs& in) {
  const CameraSpec& camera = *in.camera;
  static const char* const kNames[3] = {"R", "G", "B"};
  nlohmann::json channels = nlohmann::json::object();
  for (int c = 0; c < 3; ++c) {
    const ChannelTruthInputs& ch = in.channels[static_cast<size_t>(c)];
    const double e = ch.electrons_per_unit_reflectance;
    nlohmann::json targets = nlohmann::json::array();
    for (const auto& surface : *in.surfaces) {
      const TargetSpec& spec = surface.spec();
      const double distance_mm = surface.to_camera(0, 0)[2] * 1e3;
      const CocRange coc = camera.lens.field_focus.flat()
                               ? predicted_coc(ch.optics, camera.sensor.pixel_pitch_um, surface)
                               : coc_on_focus_surface(in, surface, c);
      auto z_i = ch.optics.image_distance_mm(distance_mm);
      const double dark = spec.dark.rgb[static_cast<size_t>(c)];
      const double light = spec.light.rgb[static_cast<size_t>(c)];
      targets.push_back({
          {"name", spec.name},
          {"image_distance_mm", z_i ? nlohmann::json(*z_i) : nlohmann::json(nullptr)},
          {"coc_px", {{"at_origin", coc.at_origin_px}, {"min", coc.min_px}, {"max", coc.max_px}}},
          {"dark_reflectance", dark},
          {"light_reflectance", light},
          {"expected_dn",
           {{"dark", expected_dn(camera.sensor, dark * e, in.gain)},
            {"light", expected_dn(camera.sensor, light * e, in.gain)}}},
      });
    }
    const double background = in.scene->background.rgb[static_cast<size_t>(c)];
    const double s_mm = ch.optics.focus_distance_mm;
    channels[kNames[c]] = {
        {"focal_mm", ch.optics.focal_mm},
        {"focus_shift_mm", camera.lens.chromatic_focus_shift_mm[static_cast<size_t>(c)]},
        // Lateral colour: the channel's image is this times the nominal one about the
        // principal point (lens.lateral_colour_px at the half diagonal).
        {"lateral_colour_px", camera.lens.lateral_colour_px[static_cast<size_t>(c)]},
        {"image_scale", channel_image_scale(camera, c)},
        // null at infinity; negative beyond it (channel_optics.h)
        {"focus_distance_m", std::isfinite(s_mm) ? nlohmann::json(s_mm / 1e3) : nullptr},
        {"quantum_efficiency", ch.quantum_efficiency},
        {"electrons_per_unit_reflectance", e},
        {"aperture_samples", ch.aperture_samples},
        {"background",
         {{"reflectance", background},
          {"expected_dn", expected_dn(camera.sensor, background * e, in.gain)}}},
        {"targets", std::move(targets)},
    };
  }
  return channels;
}

}  // namespace

nlohmann::json make_frame_truth(const TruthInputs& in) {
  const CameraSpec& camera = *in.camera;
  nlohmann::json targets = nlohmann::json::array();
  for (const auto& surface : *in.surfaces) {
    const TargetSpec& spec = surface.spec();
    const RtCamTarget& rt = in.scene->pose(spec, in.view);
    const auto origin = surface.to_camera(0, 0);
    const CocRange coc = camera.lens.field_focus.flat()
                             ? predicted_coc(camera, surface, in.f_number, in.focus_distance_mm)
                             : coc_on_focus_surface(in, surface, kGrey);
    nlohmann::json target = {
        {"name", spec.name},
        {"type", target_type_name(spec.type)},
        {"rt_cam_target", rt},
        {"distance_m", origin[2]},  // along the optical axis: the thin lens's z_o
        {"range_m",
         std::sqrt(origin[0] * origin[0] + origin[1] * origin[1] + origin[2] * origin[2])},
        {"coc_px", {{"at_origin", coc.at_origin_px}, {"min", coc.min_px}, {"max", coc.max_px}}},
    };
    if (spec.has_squares()) {
      // mrcal's order: row-major over the inner corners, corner (i, j) at
      // (i * square, j * square, 0) in the target frame. For a ChArUco board the index is
      // also the corner's ChArUco id (OpenCV numbers its inner corners row-major the same
      // way from the same corner).
      std::vector<std::array<double, 3>> points;
      for (int j = 0; j < spec.corners_rows; ++j)
        for (int i = 0; i < spec.corners_cols; ++i)
          points.push_back(surface.to_camera(i * spec.square_m, j * spec.square_m));
      target["inner_corners"] = {spec.corners_cols, spec.corners_rows};
      target["square_m"] = spec.square_m;
      target["corners_px"] = project_points(camera, in.intrinsics, points, true);
      if (spec.markers) {
        // The three marker squares (scene_spec.h): the light one first, then the dark ones
        // above it and right of it; and every corner, on the imager or not, as for ChArUco.
        const auto [a, b] = spec.marker_square();
        target["marker_squares"] = {{a, b}, {a, b - 1}, {a + 1, b}};
        target["marker_radius_m"] = TargetSpec::kMarkerRadiusSquares * spec.square_m;
        target["corners_projected_px"] = project_points(camera, in.intrinsics, points, false);
      }
      if (spec.type == TargetType::kCharuco) {
        target["squares"] = {spec.corners_cols + 1, spec.corners_rows + 1};
        target["marker_m"] = spec.marker_m;
        target["dictionary"] = spec.dictionary;
        // Every corner, on the imager or not (null only behind the camera): where a
        // partial board's missing corners would be.
        target["corners_projected_px"] = project_points(camera, in.intrinsics, points, false);
      }
    }
    if (spec.type == TargetType::kSlantedEdge) {
      // The edge segment inside the target's rectangle, through the origin along
      // (sin a, cos a); its normal (cos a, -sin a) points to the light side.
      const double a = spec.angle_deg * std::numbers::pi / 180.0;
      const double ex = std::sin(a), ey = std::cos(a);
      const double half_len =
          std::min(std::abs(ex) > 1e-12 ? spec.width_m / 2 / std::abs(ex) : 1e300,
                   std::abs(ey) > 1e-12 ? spec.height_m / 2 / std::abs(ey) : 1e300);
      const std::vector<std::array<double, 3>> points = {
          surface.to_camera(-half_len * ex, -half_len * ey), surface.to_camera(0, 0),
          surface.to_camera(half_len * ex, half_len * ey),
          surface.to_camera(1e-3 * std::cos(a), -1e-3 * std::sin(a))};
      const auto q = project_points(camera, in.intrinsics, points, false);
      target["edge_px"] = {
          {"start", q[0]}, {"middle", q[1]}, {"end", q[2]}, {"light_side_point", q[3]}};
      target["angle_deg"] = spec.angle_deg;
    }
    target["dark_reflectance"] = spec.dark_reflectance;
    target["light_reflectance"] = spec.light_reflectance;
    targets.push_back(std::move(target));
  }
  const double pitch_mm = camera.sensor.pixel_pitch_um * 1e-3;
  nlohmann::json truth = {
      {"cameramodel", truth_cameramodel_text(camera, in.intrinsics)},
      {"lensmodel", camera.lens.model},
      {"intrinsics", in.intrinsics},
      {"imagersize", {camera.sensor.width_px, camera.sensor.height_px}},
      {"pixel_pitch_um", camera.sensor.pixel_pitch_um},
      {"focal_mm", camera.lens.focal_mm},
      {"lens_to_sensor_mm", in.lens_to_sensor_mm},
      {"focus_distance_m", in.focus_distance_mm / 1e3},  // null when infinite
      {"f_number", in.f_number},
      {"aperture_mm", camera.lens.focal_mm / in.f_number},
      {"airy_diameter_px", 2.44 * 550e-6 * in.f_number / pitch_mm},
      {"baseline_blur_sigma_px", camera.lens.baseline_blur_sigma_px},
      {"electrons_per_unit_reflectance", in.electrons_per_unit_reflectance},
      {"view", in.view},
      {"targets", std::move(targets)},
  };
  if (const FieldFocusSpec& ff = camera.lens.field_focus; !ff.flat()) {
    // Where each sensor point is sharp, relative to the thin lens (field_focus.h); the
    // targets' coc_px above are through it.
    const double half_diagonal_mm =
        0.5 * std::hypot(camera.sensor.width_px, camera.sensor.height_px) * pitch_mm;
    truth["field_focus"] = {{"tilt_x_deg", ff.tilt_x_deg},
                            {"tilt_y_deg", ff.tilt_y_deg},
                            {"curvature_sag_um", ff.curvature_sag_um},
                            {"half_diagonal_mm", half_diagonal_mm},
                            {"offset_mm",
                             "X tan(tilt_x) + Y tan(tilt_y) + sag (X^2 + Y^2) / half_diagonal^2, "
                             "X and Y in mm from the principal point"}};
  }
  if (camera.sensor.is_colour()) {
    truth["cfa"] = camera.sensor.cfa;
    truth["channels"] = channels_truth(in);
  }
  return truth;
}

}  // namespace camlab::mock
