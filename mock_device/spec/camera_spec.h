// The virtual camera's specification: sensor, lens, timing and V4L2-style controls,
// read from JSON (docs/virtual-camera.md documents every field with its unit).
//
// Reentrant: plain values. Validation happens once, in parse_camera_spec; everything
// downstream trusts a CameraSpec.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "base/transfer_function.h"

namespace camlab::mock {

struct SensorSpec {
  int width_px = 0;
  int height_px = 0;
  double pixel_pitch_um = 0;
  int bit_depth = 0;  // 8..16; frames store raw DN of this many bits
  int black_level_dn = 0;
  double full_well_e = 0;               // electrons at which a pixel saturates
  double read_noise_e = 0;              // temporal read noise, electrons RMS
  bool shot_noise = true;               // Poisson photon noise; off for noise-free truth renders
  double quantum_efficiency = 0;        // electrons per photon at 555 nm, 0..1
  double conversion_gain_dn_per_e = 0;  // DN per electron at unity gain (K)
  // Colour (Bayer) sensors: the colour filter array's order over the top-left 2x2 pixels,
  // row by row ("RGGB", "BGGR", "GRBG", "GBRG"); empty for a monochrome sensor.
  std::string cfa;
  // Electrons per photon behind each channel's filter (R, G, B), the filter's
  // transmission included; quantum_efficiency for each when the spec gives none.
  std::array<double, 3> quantum_efficiency_rgb = {0, 0, 0};

  bool is_colour() const { return !cfa.empty(); }
  // The colour of pixel (x, y) of a colour sensor: 0 R, 1 G, 2 B.
  int channel_at(int x, int y) const {
    const char c = cfa[static_cast<size_t>(2 * (y & 1) + (x & 1))];
    return c == 'R' ? 0 : c == 'G' ? 1 : 2;
  }
};

struct IrisSpec {
  // f-number for each iris_absolute position 0..n-1 (V4L2: larger value = wider open),
  // so the list runs from the smallest aperture to the widest.
  std::vector<double> f_numbers;
};

struct FocusSpec {
  // focus_absolute position p puts the lens at f + p * extension_mm_per_step from the
  // sensor: p = 0 focuses at infinity, larger p focuses closer.
  int position_min = 0;
  int position_max = 0;
  double extension_mm_per_step = 0;
};

// A best-focus surface that is not flat (mock_device/render/field_focus.h): a sensor point
// (X, Y) mm from the principal point is sharp when the lens sits
//   delta = X tan(tilt_x) + Y tan(tilt_y) + sag (X^2 + Y^2) / R^2
// farther from the sensor than the thin lens's image distance (R: the imager's half
// diagonal). A sensor tilted by an angle a about the y axis is tilt_x = -a; a lens's
// Petzval field curvature is a negative sag (the corners focus closer to the lens).
// Astigmatism parts the sagittal and meridional surfaces by astigmatism_um at the corner
// (in proportion to rho^2), about that medial surface.
struct FieldFocusSpec {
  double tilt_x_deg = 0;        // the surface rises to the right (+x)
  double tilt_y_deg = 0;        // ... downward (+y)
  double curvature_sag_um = 0;  // delta at the imager's corner, less its tilt
  double astigmatism_um = 0;    // sagittal minus meridional delta at the corner
  bool flat() const {
    return tilt_x_deg == 0 && tilt_y_deg == 0 && curvature_sag_um == 0 && astigmatism_um == 0;
  }
};

struct LensSpec {
  double focal_mm = 0;
  std::string model = "LENSMODEL_PINHOLE";  // any mrcal lens model name (configured)
  std::vector<double> distortion;           // the model's parameters after fx, fy, cx, cy
  double principal_point_px[2] = {0, 0};    // cx, cy; default: the imager centre
  double f_number_min = 0;                  // widest aperture
  double f_number_max = 0;                  // smallest aperture
  IrisSpec iris;
  FocusSpec focus;
  // In-focus blur of a real lens (aberrations), as a Gaussian sigma in pixels added to
  // every frame; 0 renders a perfect thin lens.
  double baseline_blur_sigma_px = 0;
  // Longitudinal chromatic aberration (colour sensors): where R, G and B focus an object
  // at infinity, in mm behind the nominal focal length (+ = farther from the lens). Each
  // channel is a thin lens of focal length f_c = focal_mm + shift_c sharing the nominal
  // aperture (A = focal_mm / N); docs/virtual-camera.md.
  std::array<double, 3> chromatic_focus_shift_mm = {0, 0, 0};
  // Lateral chromatic aberration (colour sensors): how far each channel's image lies
  // radially outward (+) of the nominal one at the imager's corner (the half diagonal),
  // in px, growing in proportion to the distance from the principal point: channel c's
  // image scale is 1 + lateral_colour_px[c] / half_diagonal_px.
  std::array<double, 3> lateral_colour_px = {0, 0, 0};
  FieldFocusSpec field_focus;

  // Channel c's focal length (c = 0, 1, 2 for R, G, B).
  double channel_focal_mm(int c) const { return focal_mm + chromatic_focus_shift_mm[c]; }
};

struct TimingSpec {
  double frame_interval_us = 33333.3;
  int control_latency_frames = 0;  // frames until a new control value takes effect
};

// One integer V4L2 control's range (in the control's own units).
struct ControlRange {
  int min = 0;
  int max = 0;
  int step = 1;
  int default_value = 0;
};

struct ControlsSpec {
  ControlRange exposure_time_absolute;  // 100 us units; max also capped by the frame interval
  ControlRange gain;                    // linear gain = value / gain_unity
  int gain_unity = 100;
  ControlRange focus_absolute;  // = lens.focus range
  ControlRange iris_absolute;   // = 0 .. lens.iris.f_numbers.size() - 1
  bool exposure_auto = false;   // defaults of the auto modes
  bool focus_auto = false;
};

// What the camera's image processor does for the formats it makes from the sensor's
// data (RGB, YUV, JPEG).
struct IspSpec {
  int jpeg_quality = 90;  // libjpeg quality of MJPEG frames, 1..100
  // The curve the processed formats' values are encoded with, and declare (xfer_func):
  // linear (the default), or sRGB / BT.709 as a webcam's YUYV and MJPEG are.
  TransferFunction transfer = TransferFunction::kLinear;
  // false: every format leaves its colour fields (colorspace, xfer_func, ycbcr_enc,
  // quantization) at DEFAULT, as a driver that declares nothing does; the values are
  // encoded with `transfer` all the same, which a client cannot know.
  bool declares_colour_space = true;
};

// A light-field (plenoptic) camera (docs/virtual-camera.md, "Light fields"): its views
// are the images through U x V square cells of the aperture, on the sensor's pixel grid;
// with a microlens grid it also records the raw lenslet image, one U x U block of raw
// pixels behind each microlens (one microlens per sensor pixel).
struct LightFieldSpec {
  int views_u = 0, views_v = 0;  // cells per side; 0: not a light-field camera
  // "none" (views only), "square" (microlens images on a square grid, U = V), or "hex"
  // (rows of microlens images staggered by half a pitch, U = V even, rows
  // ceil(U sqrt(3) / 2) raw pixels apart).
  std::string microlens_grid = "none";
  int lenslet_margin_px = 0;  // dark raw pixels around the microlens images

  bool enabled() const { return views_u > 0; }
  bool has_lenslet() const { return microlens_grid != "none"; }
};

struct CameraSpec {
  std::string name;
  SensorSpec sensor;
  LensSpec lens;
  LightFieldSpec lightfield;
  TimingSpec timing;
  IspSpec isp;
  ControlsSpec controls;
  nlohmann::json source;  // the JSON it was read from, for provenance in manifests
};

Result<CameraSpec> parse_camera_spec(const nlohmann::json& json);
Result<CameraSpec> load_camera_spec(const std::filesystem::path& path);

// The mrcal intrinsics vector (fx, fy, cx, cy, distortion...) for the lens at a given
// lens-to-sensor distance: fx = fy = lens_to_sensor_mm / pitch_mm, because the thin lens's
// chief ray through the lens centre meets the sensor at that distance (focus breathing).
std::vector<double> intrinsics_at(const CameraSpec& spec, double lens_to_sensor_mm);

}  // namespace camlab::mock
