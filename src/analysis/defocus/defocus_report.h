// Defocus analysis of a whole capture folder: every slanted edge in every frame measured
// (edge/edge_measure.h), grouped by target, then fitted against the thin lens (coc_fits.h):
//  - frames that differ in f-number: C = k / N, the implied defocus |z_s - z_i| / z_i =
//    k pitch / f, and the thin-lens prediction of k where f, the focus distance and the
//    object distance are known;
//  - frames that differ in focus position: the V-curve, its best focus (sub-step), the
//    slope A / z_i, the object distance in best focus, and the depth of field for an
//    acceptable CoC.
// Colour captures (Bayer mosaics, linear RGB) are measured per channel; JPEG captures are
// refused ("not_linear").
// Edge geometry comes from the frames' truth (`targets[].edge_px`, virtual captures);
// without it, edges are found automatically (edge_finder.h) on the frame where most are
// found, named edge_0, edge_1, ... by length, and measured in every frame. No edge at
// all: "no_edge_geometry".
//
// Reentrant.
#pragma once

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/defocus/coc_fits.h"
#include "analysis/edge/edge_finder.h"
#include "analysis/edge/edge_measure.h"
#include "base/result.h"

namespace camlab::analysis {

struct DefocusOptions {
  double baseline_sigma_px = -1;   // < 0: from the capture (truth or camera spec), else 0
  double min_diameter_px = 1.0;    // blur below this is not used in the fits
  double acceptable_coc_px = 2.0;  // for the depth of field from the V-curve
  int threads = 1;                 // frames measured in parallel
  EdgeFinderOptions edge_finder;   // for frames without edge geometry in their truth
  const std::atomic<bool>* cancel = nullptr;  // set: stop between frames (base/cancel.h)
};

struct FrameEdge {
  int frame = 0;
  double f_number = 0;
  double focus_position = 0;
  double lens_to_sensor_mm = 0;
  std::optional<double> truth_coc_px;  // the renderer's predicted CoC at the edge's origin
  EdgeMeasurement edge;
};

struct TargetDefocus {
  std::string name;
  std::optional<double> distance_m;  // truth, when known
  std::vector<FrameEdge> frames;
  std::optional<ApertureFit> aperture;  // when the f-number varies
  std::string aperture_error;
  double implied_defocus = 0, implied_defocus_sigma = 0;  // |z_s - z_i| / z_i
  std::optional<double> thin_lens_k_px;                   // predicted C x N
  std::optional<VCurveFit> v_curve;                       // when the focus position varies
  std::string v_curve_error;
  std::optional<double> aperture_over_zi;  // A / z_i from the V slope
  std::optional<double> best_lens_to_sensor_mm;
  double mm_per_step = 0;  // lens travel per focus step, from the frames' settings
  std::optional<double> best_focus_distance_m;  // object distance in best focus
  std::optional<double> dof_near_m, dof_far_m;  // for acceptable_coc_px at best focus
  double depth_of_focus_steps = 0;              // positions with C <= acceptable CoC
};

// Longitudinal chromatic aberration of one target: where each colour channel forms its
// image, from that channel's own blur fits (chromatic_aberration.h).
struct ChromaticFocusShift {
  std::string target;
  std::string method;  // "v_curve" (best focus per channel) or "aperture" (C x N per channel)
  double image_distance_mm[3] = {0, 0, 0};  // R, G, B: lens to where the channel focuses
  double shift_r_mm = 0, shift_b_mm = 0;    // R and B relative to G, + = farther from the lens
  double shift_r_sigma_mm = 0, shift_b_sigma_mm = 0;
  // Aperture series only: the side of the sensor each channel focuses on is not in C x N;
  // it is taken from the object's distance against the focus distance (all channels on
  // that side), or assumed behind the sensor when the distance is unknown.
  bool side_assumed = false;
  std::string warning;  // e.g. a channel focused too near the sensor for its side to be sure
};

struct DefocusReport {
  std::string sweep;    // "f_number", "focus_position" or "none"
  std::string channel;  // "" for mono captures; "R", "G", "B" for one channel of colour
  double pixel_pitch_um = 0, focal_mm = 0, baseline_sigma_px = 0;
  double channel_focal_mm = 0;  // a colour channel's own focal length (truth), 0 unknown
  double acceptable_coc_px = 0;
  double focus_distance_mm = 0;  // the frames' focus distance (infinity allowed); 0 unknown
  // The lowest clip level found in the frames' histograms (raw DN), when a frame clips
  // below its white level (a full well under the ADC's top code; clip_level.h). Edges
  // with pixels at or above it are `clipped`.
  std::optional<double> clip_level_dn;
  std::vector<TargetDefocus> targets;  // mono captures, and each entry of `channels`
  // Colour captures: one report per channel (blur measured on that channel's sites at
  // full sensor resolution, in sensor pixels), and the focus shift between channels.
  std::vector<DefocusReport> channels;
  std::vector<ChromaticFocusShift> chromatic;
};

Result<DefocusReport> analyze_defocus(const std::filesystem::path& capture_dir,
                                      const DefocusOptions& options);

nlohmann::json to_json(const DefocusReport& report);

}  // namespace camlab::analysis
