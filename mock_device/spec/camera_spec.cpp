#include "mock_device/spec/camera_spec.h"

#include <algorithm>
#include <cmath>

#include "mock_device/spec/json_fields.h"
#include "mock_device/spec/mrcal_api.h"

namespace camlab::mock {

namespace {

bool is_cfa_order(const std::string& cfa) {
  return cfa == "RGGB" || cfa == "BGGR" || cfa == "GRBG" || cfa == "GBRG";
}

Result<ControlRange> parse_range(const JsonFields& f, ControlRange fallback, int hard_min,
                                 int hard_max) {
  ControlRange r;
  CAMLAB_ASSIGN(r.min, f.integer("min", hard_min, hard_max, fallback.min));
  CAMLAB_ASSIGN(r.max, f.integer("max", hard_min, hard_max, fallback.max));
  CAMLAB_ASSIGN(r.step, f.integer("step", 1, hard_max, fallback.step));
  CAMLAB_ASSIGN(r.default_value, f.integer("default", hard_min, hard_max, fallback.default_value));
  if (r.min > r.max)
    return make_error("out_of_range", f.path() + ": min " + std::to_string(r.min) +
                                          " is above max " + std::to_string(r.max));
  if (r.default_value < r.min || r.default_value > r.max)
    return make_error("out_of_range", f.path() + ".default = " + std::to_string(r.default_value) +
                                          " is outside [" + std::to_string(r.min) + ", " +
                                          std::to_string(r.max) + "]");
  return r;
}

Result<SensorSpec> parse_sensor(const JsonFields& f) {
  SensorSpec s;
  CAMLAB_ASSIGN(s.width_px, f.integer("width_px", 16, 16384));
  CAMLAB_ASSIGN(s.height_px, f.integer("height_px", 16, 16384));
  CAMLAB_ASSIGN(s.pixel_pitch_um, f.number("pixel_pitch_um", 0, 100, std::nullopt, true));
  CAMLAB_ASSIGN(s.bit_depth, f.integer("bit_depth", 8, 16, 8));
  const int max_dn = (1 << s.bit_depth) - 1;
  CAMLAB_ASSIGN(s.black_level_dn, f.integer("black_level_dn", 0, max_dn / 2, 0));
  CAMLAB_ASSIGN(s.full_well_e, f.number("full_well_e", 1, 1e7, std::nullopt));
  CAMLAB_ASSIGN(s.read_noise_e, f.number("read_noise_e", 0, 1e4, 0.0));
  CAMLAB_ASSIGN(s.shot_noise, f.boolean("shot_noise", true));
  CAMLAB_ASSIGN(s.quantum_efficiency, f.number("quantum_efficiency", 0, 1, 0.6, true));
  // Default K maps the full well onto the DN range above black: the usual design.
  const double default_gain = (max_dn - s.black_level_dn) / s.full_well_e;
  CAMLAB_ASSIGN(s.conversion_gain_dn_per_e,
                f.number("conversion_gain_dn_per_e", 0, 1e4, default_gain, true));
  CAMLAB_ASSIGN(s.cfa, f.string("cfa", ""));
  if (f.has("cfa") && !is_cfa_order(s.cfa))
    return make_error("invalid_argument", f.path_of("cfa") + " = \"" + s.cfa +
                                              "\" is not a Bayer order (RGGB, BGGR, GRBG, GBRG)");
  if (s.is_colour() && (s.width_px % 2 != 0 || s.height_px % 2 != 0))
    return make_error("invalid_argument",
                      f.path() + ": a Bayer sensor has whole 2x2 colour cells; " +
                          std::to_string(s.width_px) + "x" + std::to_string(s.height_px) +
                          " px must be even in both directions");
  s.quantum_efficiency_rgb = {s.quantum_efficiency, s.quantum_efficiency, s.quantum_efficiency};
  if (f.has("quantum_efficiency_rgb")) {
    if (!s.is_colour())
      return make_error("invalid_argument", f.path_of("quantum_efficiency_rgb") +
                                                " needs a colour sensor (" + f.path_of("cfa") +
                                                "); a monochrome sensor has quantum_efficiency");
    std::vector<double> qe;
    CAMLAB_ASSIGN(qe, f.numbers("quantum_efficiency_rgb", 3, 3, 0, 1));
    for (int c = 0; c < 3; ++c) {
      if (qe[c] <= 0)
        return make_error("out_of_range", f.path_of("quantum_efficiency_rgb") + "[" +
                                              std::to_string(c) +
                                              "] = 0: a channel must see light "
                                              "(0 < QE <= 1)");
      s.quantum_efficiency_rgb[c] = qe[c];
    }
  }
  return s;
}

Result<LensSpec> parse_lens(const JsonFields& f, const SensorSpec& sensor) {
  LensSpec lens;
  CAMLAB_ASSIGN(lens.focal_mm, f.number("focal_mm", 0, 10000, std::nullopt, true));
  CAMLAB_ASSIGN(lens.model, f.string("model", "LENSMODEL_PINHOLE"));
  mrcal_lensmodel_t lensmodel;
  if (!mrcal_lensmodel_from_name(&lensmodel, lens.model.c_str()) ||
      !mrcal_lensmodel_type_is_valid(lensmodel.type))
    return make_error("invalid_argument",
                      f.path_of("model") + " = \"" + lens.model +
                          "\" is not an mrcal lens model (e.g. LENSMODEL_OPENCV8, "
                          "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=10_fov_x_deg=100)");
  if (lensmodel.type == MRCAL_LENSMODEL_CAHVORE)
    return make_error(
        "invalid_argument",
        f.path_of("model") + ": CAHVORE cannot be unprojected by mrcal; choose another");
  if (!mrcal_lensmodel_metadata(&lensmodel).has_core)
    return make_error("invalid_argument",
                      f.path_of("model") + " has no intrinsics core (fx fy cx cy)");
  const size_t n_distortion = static_cast<size_t>(mrcal_lensmodel_num_params(&lensmodel) - 4);
  if (n_distortion == 0) {
    lens.distortion.clear();
    if (f.has("distortion") && !f.json().at("distortion").empty())
      return make_error("invalid_argument",
                        f.path_of("distortion") + " must be empty for " + lens.model);
  } else {
    CAMLAB_ASSIGN(lens.distortion, f.numbers("distortion", n_distortion, n_distortion));
  }
  if (f.has("principal_point_px")) {
    std::vector<double> pp;
    CAMLAB_ASSIGN(pp, f.numbers("principal_point_px", 2, 2, 0, 16384));
    lens.principal_point_px[0] = pp[0];
    lens.principal_point_px[1] = pp[1];
  } else {
    // Pixel centres are at integer coordinates (mrcal, OpenCV), so the middle of a
    // W-pixel row is at (W - 1) / 2.
    lens.principal_point_px[0] = (sensor.width_px - 1) / 2.0;
    lens.principal_point_px[1] = (sensor.height_px - 1) / 2.0;
  }
  CAMLAB_ASSIGN(lens.f_number_min, f.number("f_number_min", 0.5, 128, 2.0));
  CAMLAB_ASSIGN(lens.f_number_max, f.number("f_number_max", lens.f_number_min, 128, 16.0));
  CAMLAB_ASSIGN(lens.baseline_blur_sigma_px, f.number("baseline_blur_sigma_px", 0, 50, 0.0));
  // Colour aberrations need colour channels.
  auto needs_colour = [&](const char* key) {
    return make_error("invalid_argument",
                      f.path_of(key) +
                          " needs a colour sensor (camera.sensor.cfa): a monochrome sensor "
                          "sees every colour at once, which the virtual camera does not model");
  };
  if (f.has("chromatic_focus_shift_mm")) {
    if (!sensor.is_colour()) return needs_colour("chromatic_focus_shift_mm");
    // Real lenses shift a few tenths of a percent of f; a tenth of f is far beyond any
    // lens and keeps every channel's focal length positive.
    const double bound_mm = 0.1 * lens.focal_mm;
    std::vector<double> shift;
    CAMLAB_ASSIGN(shift, f.numbers("chromatic_focus_shift_mm", 3, 3, -bound_mm, bound_mm));
    for (int c = 0; c < 3; ++c) lens.chromatic_focus_shift_mm[c] = shift[c];
  }

  if (f.has("lateral_colour_px")) {
    if (!sensor.is_colour()) return needs_colour("lateral_colour_px");
    // A real lens's lateral colour is a few pixels at the corner at most.
    std::vector<double> shift;
    CAMLAB_ASSIGN(shift, f.numbers("lateral_colour_px", 3, 3, -20, 20));
    for (int c = 0; c < 3; ++c) lens.lateral_colour_px[static_cast<size_t>(c)] = shift[c];
  }
  // Tilt and curvature of the best-focus surface. Bounds far beyond real lenses (a module's
  // tilt is a few tenths of a degree, its curvature tens of um) that keep every point's
  // lens-to-sensor distance a thin lens's.
  JsonFields field = f.child("field_focus");
  CAMLAB_ASSIGN(lens.field_focus.tilt_x_deg, field.number("tilt_x_deg", -5, 5, 0.0));
  CAMLAB_ASSIGN(lens.field_focus.tilt_y_deg, field.number("tilt_y_deg", -5, 5, 0.0));
  const double sag_bound_um = 100 * lens.focal_mm;  // a tenth of f
  CAMLAB_ASSIGN(lens.field_focus.curvature_sag_um,
                field.number("curvature_sag_um", -sag_bound_um, sag_bound_um, 0.0));
  CAMLAB_ASSIGN(lens.field_focus.astigmatism_um,
                field.number("astigmatism_um", -sag_bound_um, sag_bound_um, 0.0));

  JsonFields iris = f.child("iris");
  if (iris.has("f_numbers")) {
    CAMLAB_ASSIGN(lens.iris.f_numbers,
                  iris.numbers("f_numbers", 1, 64, lens.f_number_min, lens.f_number_max));
    if (!std::is_sorted(lens.iris.f_numbers.rbegin(), lens.iris.f_numbers.rend()) ||
        std::adjacent_find(lens.iris.f_numbers.begin(), lens.iris.f_numbers.end()) !=
            lens.iris.f_numbers.end())
      return make_error("invalid_argument",
                        iris.path_of("f_numbers") +
                            " must fall strictly from the smallest aperture to the "
                            "widest (iris_absolute: larger value = wider open)");
  } else {
    // Full stops from the smallest aperture down to the widest.
    // Full stops from the smallest aperture down to the widest, clamped onto the range so
    // that rounding (16 / sqrt(2)^6 = 1.9999...) never falls outside it.
    for (double n = lens.f_number_max; n >= lens.f_number_min * 0.999; n /= std::sqrt(2.0))
      lens.iris.f_numbers.push_back(std::clamp(n, lens.f_number_min, lens.f_number_max));
  }

  JsonFields focus = f.child("focus");
  CAMLAB_ASSIGN(lens.focus.position_min, focus.integer("position_min", 0, 1 << 20, 0));
  CAMLAB_ASSIGN(lens.focus.position_max,
                focus.integer("position_max", lens.focus.position_min, 1 << 20, 1000));
  // Default: the full travel reaches a magnification of 0.1 (focus at 11 f).
  CAMLAB_ASSIGN(lens.focus.extension_mm_per_step,
                focus.number("extension_mm_per_step", 0, 1000,
                             0.1 * lens.focal_mm / std::max(1, lens.focus.position_max), true));
  return lens;
}

Result<LightFieldSpec> parse_lightfield(const JsonFields& f, const SensorSpec& sensor,
                                        const LensSpec& lens) {
  LightFieldSpec lf;
  if (!f.has("views")) {
    if (!f.json().empty())
      return make_error("invalid_argument", f.path_of("views") + " is required ([U, V])");
    return lf;
  }
  // At most 16 x 16 cells: a frame's light field is held in memory as 4 bytes per cell
  // and pixel (256 cells of 640 x 480: 315 MB).
  std::vector<double> views;
  CAMLAB_ASSIGN(views, f.numbers("views", 2, 2, 1, 16));
  if (views[0] != std::floor(views[0]) || views[1] != std::floor(views[1]))
    return make_error("invalid_argument", f.path_of("views") + " must be whole numbers of views");
  lf.views_u = static_cast<int>(views[0]);
  lf.views_v = static_cast<int>(views[1]);
  CAMLAB_ASSIGN(lf.microlens_grid, f.string("microlens_grid", "none"));
  if (lf.microlens_grid != "none" && lf.microlens_grid != "square" && lf.microlens_grid != "hex")
    return make_error("invalid_argument", f.path_of("microlens_grid") + " = \"" +
                                              lf.microlens_grid +
                                              "\" is not one of none, square, hex");
  if (lf.has_lenslet() && lf.views_u != lf.views_v)
    return make_error("invalid_argument",
                      f.path_of("views") + " = [" + std::to_string(lf.views_u) + ", " +
                          std::to_string(lf.views_v) +
                          "]: a microlens images the round aperture onto a square block of raw "
                          "pixels, so U and V must be equal");
  if (lf.microlens_grid == "hex" && lf.views_u % 2 != 0)
    return make_error("invalid_argument",
                      f.path_of("views") + " = " + std::to_string(lf.views_u) +
                          " per side: a hexagonal grid staggers its rows by half a pitch, which "
                          "falls on a whole raw pixel only for an even number of views per side");
  CAMLAB_ASSIGN(lf.lenslet_margin_px, f.integer("lenslet_margin_px", 0, 64, 0));
  if (sensor.is_colour())
    return make_error("unsupported", f.path() +
                                         ": light fields are rendered for monochrome sensors "
                                         "(a raw lenslet image's colour filters do not follow "
                                         "the views' pixels)");
  if (!lens.field_focus.flat())
    return make_error("unsupported", f.path() +
                                         ": light fields are rendered with a flat focus "
                                         "surface; leave camera.lens.field_focus out");
  if (lens.model != "LENSMODEL_PINHOLE")
    return make_error("unsupported",
                      f.path() + ": a light-field camera needs lens.model LENSMODEL_PINHOLE, not " +
                          lens.model +
                          " (refocusing and depth shift the views by whole-image "
                          "disparities, which a distorted lens does not have)");
  return lf;
}

}  // namespace

Result<CameraSpec> parse_camera_spec(const nlohmann::json& json) {
  if (!json.is_object()) return make_error("invalid_argument", "camera spec must be a JSON object");
  JsonFields root(json, "camera");
  CameraSpec spec;
  spec.source = json;
  CAMLAB_ASSIGN(spec.name, root.string("name", "camlab virtual camera"));
  CAMLAB_ASSIGN(spec.sensor, parse_sensor(root.child("sensor")));
  CAMLAB_ASSIGN(spec.lens, parse_lens(root.child("lens"), spec.sensor));
  CAMLAB_ASSIGN(spec.lightfield,
                parse_lightfield(root.child("lightfield"), spec.sensor, spec.lens));

  JsonFields timing = root.child("timing");
  CAMLAB_ASSIGN(spec.timing.frame_interval_us,
                timing.number("frame_interval_us", 100, 10e6, 33333.3));
  CAMLAB_ASSIGN(spec.timing.control_latency_frames,
                timing.integer("control_latency_frames", 0, 16, 0));

  JsonFields isp = root.child("isp");
  CAMLAB_ASSIGN(spec.isp.jpeg_quality, isp.integer("jpeg_quality", 1, 100, 90));
  std::string transfer;
  CAMLAB_ASSIGN(transfer, isp.string("transfer", "linear"));
  const auto named = transfer_function_named(transfer);
  if (!named || *named == TransferFunction::kOther)
    return make_error("invalid_argument",
                      "isp.transfer must be \"linear\", \"srgb\" or "
                      "\"bt709\", not \"" +
                          transfer + "\"");
  spec.isp.transfer = *named;
  CAMLAB_ASSIGN(spec.isp.declares_colour_space, isp.boolean("declares_colour_space", true));

  JsonFields controls = root.child("controls");
  // exposure_time_absolute is in 100 us units and cannot exceed the frame interval.
  const int exposure_cap = std::max(1, static_cast<int>(spec.timing.frame_interval_us / 100.0));
  CAMLAB_ASSIGN(spec.controls.exposure_time_absolute,
                parse_range(controls.child("exposure_time_absolute"),
                            {1, exposure_cap, 1, std::min(100, exposure_cap)}, 1, 1 << 24));
  if (spec.controls.exposure_time_absolute.max > exposure_cap)
    return make_error("out_of_range", controls.path_of("exposure_time_absolute") + ".max = " +
                                          std::to_string(spec.controls.exposure_time_absolute.max) +
                                          " (x 100 us) exceeds the frame interval of " +
                                          std::to_string(spec.timing.frame_interval_us) + " us");
  CAMLAB_ASSIGN(spec.controls.gain_unity, controls.child("gain").integer("unity", 1, 1 << 20, 100));
  CAMLAB_ASSIGN(spec.controls.gain,
                parse_range(controls.child("gain"),
                            {spec.controls.gain_unity, 16 * spec.controls.gain_unity, 1,
                             spec.controls.gain_unity},
                            1, 1 << 24));
  spec.controls.focus_absolute = {spec.lens.focus.position_min, spec.lens.focus.position_max, 1,
                                  spec.lens.focus.position_min};
  CAMLAB_ASSIGN(spec.controls.focus_absolute.default_value,
                controls.child("focus_absolute")
                    .integer("default", spec.lens.focus.position_min, spec.lens.focus.position_max,
                             spec.lens.focus.position_min));
  const int iris_positions = static_cast<int>(spec.lens.iris.f_numbers.size());
  spec.controls.iris_absolute = {0, iris_positions - 1, 1, iris_positions - 1};
  CAMLAB_ASSIGN(spec.controls.iris_absolute.default_value,
                controls.child("iris_absolute")
                    .integer("default", 0, iris_positions - 1, iris_positions - 1));
  CAMLAB_ASSIGN(spec.controls.exposure_auto, controls.boolean("exposure_auto", false));
  CAMLAB_ASSIGN(spec.controls.focus_auto, controls.boolean("focus_auto", false));
  return spec;
}

Result<CameraSpec> load_camera_spec(const std::filesystem::path& path) {
  auto json = read_json_file(path);
  if (!json) return json.error();
  auto spec = parse_camera_spec(*json);
  if (!spec) return make_error(spec.error().code, path.string() + ": " + spec.error().message);
  return spec;
}

std::vector<double> intrinsics_at(const CameraSpec& spec, double lens_to_sensor_mm) {
  const double f_px = lens_to_sensor_mm / (spec.sensor.pixel_pitch_um * 1e-3);
  std::vector<double> intrinsics = {f_px, f_px, spec.lens.principal_point_px[0],
                                    spec.lens.principal_point_px[1]};
  intrinsics.insert(intrinsics.end(), spec.lens.distortion.begin(), spec.lens.distortion.end());
  return intrinsics;
}

}  // namespace camlab::mock
