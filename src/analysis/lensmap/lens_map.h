// `camlab analyze lensmap`: the lens across its field from a focus sweep. Every edge's
// MTF50 through focus (the SFR of sfr/sfr_image.h, the same edges on every frame) gives
// that field position's best focus; the best foci over the field give the best-focus
// surface: its focus on the axis, its tilt, its curvature (field curvature) and, from the
// edges the field classes apart, the sagittal and meridional surfaces' difference
// (astigmatism); on colour frames, each channel's best focus and R's and B's against G's
// (longitudinal colour). One surface per f-number of the sweep, each number with its
// standard error.
//
// Best focus of one edge: blur widths add in quadrature (a Gaussian blur of the lens's own
// width sigma_0 and a defocus blur growing linearly with the distance from best focus), so
// 1 / MTF50^2, proportional to the blur's variance, is a parabola in the focus position,
// sigma_0^2 + k^2 (p - p_best)^2: fitted by least squares to the points of the sweep whose
// MTF50 is at least a quarter of the edge's highest, its vertex is the best focus. Exact for a
// Gaussian blur; a lens's disk-shaped defocus blur departs from it between focus and far
// defocus (where MTF50 ~ 1 / the disk's diameter is a parabola again), alike on both
// sides of the peak (docs/analysis.md, "Lens map").
//
// The surface: best focus p(u, v) = p0 + t_x u + t_y v + c rho^2, u and v the field
// coordinates relative to the image centre in units of the half diagonal (rho = 1 at the
// corner); apart, a sagittal and a meridional curvature (c_s, c_m), their difference the
// astigmatism at the corner. An edge whose normal makes an angle theta with the radius is
// blurred across itself by the radial part of the pencil (meridional focus) as cos^2 theta
// and by the tangential part (sagittal) as sin^2 theta, so its best focus is the mix
// p0 + t_x u + t_y v + rho^2 (c_m cos^2 theta + c_s sin^2 theta): every edge tells the two
// apart by its orientation (an oblique edge classed as either would pull them together). Positions
// are in the sweep's focus units (V4L2 focus_absolute steps); with the camera's lens extension per
// step and pixel pitch (a capture of the virtual camera carries both) also in micrometres
// at the sensor and the tilt in degrees.
//
// Reentrant.
#pragma once

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/sfr/sfr_image.h"
#include "base/result.h"

namespace camlab::analysis {

// Why an edge has no best focus.
inline constexpr std::string_view kBestFocusOk = "ok";
// A segment the edge finder took on the frame it searched that the SFR measured on no frame
// (a corner's short side, a shadow): no edge, rather than one that failed.
inline constexpr std::string_view kBestFocusNotMeasured = "not_measured";
inline constexpr std::string_view kBestFocusTooFewPoints = "too_few_points";
inline constexpr std::string_view kBestFocusAtSweepEnd = "peak_at_sweep_end";
inline constexpr std::string_view kBestFocusNotAPeak = "not_a_peak";
inline constexpr std::string_view kBestFocusOffSurface = "off_surface";  // left out of the fit

struct EdgeBestFocus {
  std::string name;
  double centre_x_px = 0, centre_y_px = 0;
  std::string field;       // sagittal, meridional, oblique or axial (sfr_image.h)
  double angle_deg = NAN;  // the edge's direction in the image (sfr's angle_deg)
  std::string status{kBestFocusOk};
  double best_focus = 0;  // focus position, the sweep's units
  double peak_mtf50_cy_px = 0;
  int points = 0;  // through-focus points the parabola was fitted to
  // The edge's MTF50 (cycles/px) at each focus position it was measured at, in focus order.
  std::vector<std::pair<double, double>> through_focus;
};

// One colour channel's best focus (colour frames: the SFR of each channel on its own
// sites, sfr_image.h). Longitudinal colour is the channel's best focus minus green's, the
// mean over the edges both measured of their per-edge difference: what the edges share
// (their place, their shape) cancels, so it is far tighter than the two surfaces' axes.
struct ChannelFocus {
  std::string channel;  // R, G or B
  int edges_used = 0;
  double centre_focus = 0, centre_focus_sigma = 0;       // the channel's own surface on the axis
  std::optional<double> minus_green, minus_green_sigma;  // R and B: focus units
  int edges_paired = 0;                                  // edges in the difference
  // Lateral colour (R and B): how far the channel's image lies radially outward of green's
  // at the imager's corner (px), fitted over every frame's edges as s r.n: each edge's
  // offset across its line from green's (the SFR's per-channel offset_px) against its
  // distance from the centre along its normal.
  std::optional<double> lateral_px_at_corner, lateral_px_sigma;
  int lateral_samples = 0;  // edge fits (frames x edges) in the fit
};

struct FocusSurface {
  double f_number = 0;  // 0: the sweep's frames give none
  int edges_used = 0;
  double centre_focus = 0;        // p0: best focus on the axis
  double tilt_x = 0, tilt_y = 0;  // focus units per half diagonal, to the right / down
  // c: best focus at the corner minus on the axis; with the classes apart, the medial
  // surface's (c_s + c_m) / 2.
  double curvature = 0;
  std::optional<double> curvature_sagittal, curvature_meridional;  // c_s, c_m
  double rms_residual = 0;  // of the edges' best foci about the surface (the two, when fitted)
  // 1-sigma standard errors of the above, from the edges' scatter about the surface (the
  // least-squares covariance): the same units.
  struct StandardErrors {
    double centre_focus = 0, tilt_x = 0, tilt_y = 0, curvature = 0;
    std::optional<double> astigmatism;  // of c_s - c_m
  } sigma;
  std::vector<ChannelFocus> channels;  // colour frames: R, G, B; else empty
  std::vector<EdgeBestFocus> edges;
};

struct LensMapOptions {
  SfrImageOptions sfr;
  // Sensor-side lens movement per focus unit (mm) and pixel pitch (um): 0 reads them from
  // the capture's camera spec when it has them; without them the surface is in focus units.
  double extension_mm_per_step = 0;
  double pixel_pitch_um = 0;
};

struct LensMapReport {
  nlohmann::json report;
  std::string text;
};

// The lens map of an SFR report of a capture folder (analyze_sfr_folder's "frames", with
// each frame's settings and "size_px"). Errors: "too_few_samples" (fewer than 5 focus
// positions at every f-number, or fewer than 5 edges with a best focus), "singular" (the
// edges do not spread over the field enough to tell tilt and curvature apart).
Result<std::vector<FocusSurface>> focus_surfaces(const nlohmann::json& sfr_report);

// The whole run on a capture folder: SFR of every frame, the surfaces, the report.
Result<LensMapReport> analyze_lens_map(const std::filesystem::path& dir,
                                       const LensMapOptions& options);

}  // namespace camlab::analysis
