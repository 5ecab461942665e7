// Capture-folder defocus analysis: measurement per frame, fits per target.
#include "analysis/defocus/defocus_report.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <thread>

#include <opencv2/core.hpp>

#include "analysis/channel_signal.h"
#include "analysis/clip_level.h"
#include "analysis/defocus/chromatic_aberration.h"
#include "analysis/edge/edge_finder.h"
#include "base/cancel.h"
#include "image/capture_folder.h"
#include "image/frame_views.h"
#include "optics/optics.h"

namespace camlab::analysis {
namespace {

using nlohmann::json;

double number_or(const json& j, const char* key, double fallback) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return fallback;
  return j[key].get<double>();
}

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

bool point_of(const json& j, double* x, double* y) {
  if (!j.is_array() || j.size() < 2 || !j[0].is_number() || !j[1].is_number()) return false;
  *x = j[0].get<double>();
  *y = j[1].get<double>();
  return std::isfinite(*x) && std::isfinite(*y);
}

// The target's size from the scene spec in the manifest, by name.
const json* scene_target(const json& manifest, const std::string& name) {
  const json* scene = nullptr;
  if (manifest.contains("source") && manifest["source"].contains("scene_spec"))
    scene = &manifest["source"]["scene_spec"];
  if (!scene || !scene->contains("targets") || !(*scene)["targets"].is_array()) return nullptr;
  for (const json& t : (*scene)["targets"])
    if (t.value("name", std::string()) == name) return &t;
  return nullptr;
}

// Edges of slanted-edge targets from a frame's truth. The half-width across the edge is
// bounded by the target's sides (from the scene spec's size when present, else half the
// edge's length, right for a square target).
std::vector<EdgeSegment> edges_from_truth(const json& truth, const json& manifest,
                                          std::vector<const json*>* targets) {
  std::vector<EdgeSegment> edges;
  if (!truth.is_object() || !truth.contains("targets")) return edges;
  for (const json& t : truth["targets"]) {
    if (!t.contains("edge_px") || !t["edge_px"].is_object()) continue;
    const json& e = t["edge_px"];
    EdgeSegment s;
    s.name = t.value("name", std::string("edge"));
    double mx, my, lx, ly;
    if (!point_of(e["start"], &s.start_x_px, &s.start_y_px) ||
        !point_of(e["end"], &s.end_x_px, &s.end_y_px) || !point_of(e["middle"], &mx, &my) ||
        !point_of(e["light_side_point"], &lx, &ly))
      continue;
    const double length = std::hypot(s.end_x_px - s.start_x_px, s.end_y_px - s.start_y_px);
    s.max_half_width_px = 0.5 * length;
    const json* spec = scene_target(manifest, s.name);
    const double px_per_m = std::hypot(lx - mx, ly - my) / 1e-3;
    if (spec && spec->contains("size_m") && (*spec)["size_m"].size() == 2) {
      const double a = number_or(t, "angle_deg", 5.0) * std::numbers::pi / 180.0;
      const double w = (*spec)["size_m"][0].get<double>(), h = (*spec)["size_m"][1].get<double>();
      s.max_half_width_px =
          std::max(0.0, px_per_m * (0.5 * w * std::cos(a) - 0.5 * h * std::fabs(std::sin(a))));
    }
    edges.push_back(s);
    targets->push_back(&t);
  }
  return edges;
}

// A target's entry in a colour channel's truth, by name.
const json* channel_target(const json* channel_truth, const std::string& name) {
  if (!channel_truth || !channel_truth->contains("targets") ||
      !(*channel_truth)["targets"].is_array())
    return nullptr;
  for (const json& t : (*channel_truth)["targets"])
    if (t.value("name", std::string()) == name) return &t;
  return nullptr;
}

struct FrameResult {
  Status status;
  std::vector<FrameEdge> edges;
  std::vector<std::optional<double>> distances;
  double pitch_um = 0, focal_mm = 0, channel_focal_mm = 0, baseline = 0;
  std::optional<double> clip_level_dn;  // detected from the frame's histogram
};

// `detected`: edges found automatically (used when the frame's truth has none).
// Whether the frames can show diffraction: a real lens always does; the virtual camera's
// renderer does not model it (docs/virtual-camera.md) unless its lens spec says
// "diffraction": true. Flagging its sharp edges below_diffraction_floor (8 of 14 rows on
// the review's aperture series) told a user about physics the data did not have.
bool frames_show_diffraction(const image::CaptureFolder& folder) {
  const json& source = folder.manifest().value("source", json::object());
  if (!source.is_object() || !source.contains("camera_spec")) return true;
  const json& lens = source["camera_spec"].value("lens", json::object());
  return lens.is_object() && lens.value("diffraction", false) == true;
}

FrameResult measure_frame(const image::CaptureFolder& folder, int index,
                          const DefocusOptions& options, const std::vector<EdgeSegment>& detected,
                          const std::string& channel) {
  FrameResult out;
  auto side = folder.load_sidecar(index);
  if (!side) {
    out.status = side.error();
    return out;
  }
  auto image = folder.load_stored_image(index);
  if (!image) {
    out.status = image.error();
    return out;
  }
  // A frame with the curve its camera declared (a webcam's YUYV) is decoded to light:
  // the blur is fitted to the light's edge profile.
  auto light = image::decode_to_light(*image, *side);
  if (!light) {
    out.status = light.error();
    return out;
  }
  *image = std::move(light->stored);
  *side = std::move(light->sidecar);
  auto signal = channel_signal(*image, *side, channel);
  if (!signal) {
    out.status = signal.error();
    return out;
  }
  const json& camera = folder.manifest().contains("source")
                           ? folder.manifest()["source"].value("camera_spec", json::object())
                           : json::object();
  const json& truth = side->truth;
  // A colour channel's own optics, where the truth gives them (longitudinal chromatic
  // aberration: each channel has its focal length and its CoC).
  const json* channel_truth = nullptr;
  if (!channel.empty() && truth.is_object() && truth.contains("channels") &&
      truth["channels"].is_object() && truth["channels"].contains(channel))
    channel_truth = &truth["channels"][channel];
  out.pitch_um = number_or(truth, "pixel_pitch_um",
                           number_or(camera.value("sensor", json::object()), "pixel_pitch_um", 0));
  out.focal_mm =
      number_or(truth, "focal_mm", number_or(camera.value("lens", json::object()), "focal_mm", 0));
  // The aperture is f / N of the nominal focal length for every channel; a channel's own
  // focal length moves only where it focuses.
  if (channel_truth) out.channel_focal_mm = number_or(*channel_truth, "focal_mm", 0);
  out.baseline = options.baseline_sigma_px >= 0
                     ? options.baseline_sigma_px
                     : number_or(truth, "baseline_blur_sigma_px",
                                 number_or(camera.value("lens", json::object()),
                                           "baseline_blur_sigma_px", 0.0));
  std::vector<const json*> targets;
  std::vector<EdgeSegment> edges = edges_from_truth(truth, folder.manifest(), &targets);
  if (edges.empty()) {
    edges = detected;
    targets.assign(edges.size(), nullptr);
  }
  if (edges.empty()) {
    out.status = make_error("no_edge_geometry",
                            "frame " + std::to_string(index) +
                                " has no slanted-edge geometry in its truth and no straight edge "
                                "was found in the capture");
    return out;
  }
  const json& settings = side->settings;
  const double f_number = number_or(settings, "f_number", number_or(truth, "f_number", 0));
  EdgeMeasureOptions mo;
  mo.baseline_sigma_px = out.baseline;
  mo.saturation_level = side->white_level_dn - side->black_level_dn;
  // A full well below the ADC's top code clips lower than the white level: the frame's
  // histogram shows it (clip_level.h).
  if (image->channels() == 1) {
    if (auto plateau = detect_clip_plateau(*image, side->black_level_dn)) {
      out.clip_level_dn = plateau->level_dn;
      mo.saturation_level = std::min(mo.saturation_level, plateau->level_dn - side->black_level_dn);
    }
  }
  if (out.pitch_um > 0 && f_number > 0 && frames_show_diffraction(folder))
    mo.airy_diameter_px = 2.44 * 0.55 * f_number / out.pitch_um;
  for (size_t i = 0; i < edges.size(); ++i) {
    auto m = measure_edge(*signal, edges[i], edges, mo);
    if (!m) {
      out.status = m.error();
      return out;
    }
    FrameEdge fe;
    fe.frame = index;
    fe.f_number = f_number;
    fe.focus_position = number_or(settings, "focus_position", 0);
    fe.lens_to_sensor_mm = number_or(settings, "lens_to_sensor_mm", 0);
    const json* t = targets[i];
    if (t && t->contains("coc_px")) fe.truth_coc_px = number_or((*t)["coc_px"], "at_origin", 0);
    if (const json* ct = channel_target(channel_truth, edges[i].name); ct && ct->contains("coc_px"))
      fe.truth_coc_px = number_or((*ct)["coc_px"], "at_origin", 0);
    fe.edge = std::move(*m);
    out.edges.push_back(std::move(fe));
    out.distances.push_back(t && t->contains("distance_m") && (*t)["distance_m"].is_number()
                                ? std::optional<double>((*t)["distance_m"].get<double>())
                                : std::nullopt);
  }
  return out;
}

BlurSample sample_of(const FrameEdge& fe, double x) {
  BlurSample s;
  s.x = x;
  s.diameter_px = fe.edge.diameter_px;
  s.sigma_px = fe.edge.measured() ? fe.edge.diameter_sigma_px : 0.0;  // others skipped
  return s;
}

void fit_aperture(TargetDefocus* t, const DefocusReport& r, const DefocusOptions& options,
                  double focus_distance_mm) {
  std::vector<BlurSample> samples;
  for (const FrameEdge& fe : t->frames) samples.push_back(sample_of(fe, fe.f_number));
  auto fit = fit_coc_vs_aperture(samples, options.min_diameter_px);
  if (!fit) {
    t->aperture_error = fit.error().text();
    return;
  }
  t->aperture = *fit;
  if (r.focal_mm > 0 && r.pixel_pitch_um > 0) {
    // C / A = (k / N) pitch / (f / N) = k pitch / f.
    t->implied_defocus = fit->k_px * r.pixel_pitch_um * 1e-3 / r.focal_mm;
    t->implied_defocus_sigma = fit->k_sigma_px * r.pixel_pitch_um * 1e-3 / r.focal_mm;
    if (t->distance_m && r.channel_focal_mm > 0 && !t->frames.empty() &&
        t->frames.front().lens_to_sensor_mm > 0) {
      // A colour channel with its own focal length f_c: its image of the object lies at
      // z_i = 1 / (1/f_c - 1/z_o), the sensor where the lens is (z_s), and the blur
      // disk is (f / N) |z_s - z_i| / z_i, so C x N = f |z_s - z_i| / z_i.
      auto zi = optics::image_distance_mm(r.channel_focal_mm, *t->distance_m * 1e3);
      const double zs = t->frames.front().lens_to_sensor_mm;
      if (zi)
        t->thin_lens_k_px = r.focal_mm * std::fabs(zs - *zi) / *zi / (r.pixel_pitch_um * 1e-3);
    } else if (t->distance_m && focus_distance_mm > 0) {
      auto c =
          optics::circle_of_confusion_mm(r.focal_mm, 1.0, focus_distance_mm, *t->distance_m * 1e3);
      if (c) t->thin_lens_k_px = *c / (r.pixel_pitch_um * 1e-3);
    }
  }
}

void fit_focus(TargetDefocus* t, const DefocusReport& r, const DefocusOptions& options) {
  std::vector<BlurSample> samples;
  for (const FrameEdge& fe : t->frames) samples.push_back(sample_of(fe, fe.focus_position));
  auto fit = fit_v_curve(samples, options.min_diameter_px);
  if (!fit) {
    t->v_curve_error = fit.error().text();
    return;
  }
  t->v_curve = *fit;
  t->depth_of_focus_steps = 2.0 * options.acceptable_coc_px / fit->slope_px_per_step;
  // Lens-to-sensor distance against position: a line through the frames' settings.
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(t->frames.size());
  for (const FrameEdge& fe : t->frames) {
    sx += fe.focus_position;
    sy += fe.lens_to_sensor_mm;
    sxx += fe.focus_position * fe.focus_position;
    sxy += fe.focus_position * fe.lens_to_sensor_mm;
  }
  const double det = n * sxx - sx * sx;
  if (!(det > 0) || r.pixel_pitch_um <= 0 || r.focal_mm <= 0) return;
  const double mm_per_step = (n * sxy - sx * sy) / det, intercept = (sy - mm_per_step * sx) / n;
  if (!(mm_per_step > 0)) return;
  t->mm_per_step = mm_per_step;
  t->aperture_over_zi = fit->slope_px_per_step * r.pixel_pitch_um * 1e-3 / mm_per_step;
  const double zs = intercept + mm_per_step * fit->best_position;
  t->best_lens_to_sensor_mm = zs;
  auto s_mm = optics::focus_distance_mm(r.focal_mm, zs);
  if (!s_mm) return;
  t->best_focus_distance_m = *s_mm * 1e-3;
  const double f_number = t->frames.front().f_number;
  auto dof = optics::depth_of_field(r.focal_mm, f_number, *s_mm,
                                    options.acceptable_coc_px * r.pixel_pitch_um * 1e-3);
  if (dof) {
    t->dof_near_m = dof->near_mm * 1e-3;
    t->dof_far_m = dof->far_mm * 1e-3;  // +infinity beyond the hyperfocal distance
  }
}

// Edges found automatically, for captures whose truth has no edge geometry: on every
// frame (colour frames in their luminance), keeping the frame where most are found (the
// sharpest, usually), and used for all frames (the fit refines each edge's position and
// angle per frame).
Result<std::vector<EdgeSegment>> detect_edges(const image::CaptureFolder& folder,
                                              const DefocusOptions& options) {
  std::vector<EdgeSegment> detected;
  const int count = static_cast<int>(folder.frames().size());
  auto first = folder.load_sidecar(0);
  if (!first) return first.error();
  std::vector<const json*> unused;
  if (!edges_from_truth(first->truth, folder.manifest(), &unused).empty()) return detected;
  for (int i = 0; i < count; ++i) {
    if (Status s = check_not_cancelled(options.cancel, "analysis"); !s) return s.error();
    auto side = folder.load_sidecar(i);
    if (!side) return side.error();
    auto stored = folder.load_stored_image(i);
    if (!stored) return stored.error();
    auto luminance = image::luminance_view(*stored, *side);
    if (!luminance) return luminance.error();
    std::vector<EdgeSegment> found = find_edges(*luminance, options.edge_finder);
    if (found.size() > detected.size()) detected = std::move(found);
  }
  return detected;
}

Result<DefocusReport> analyze_channel(const image::CaptureFolder& folder,
                                      const DefocusOptions& options,
                                      const std::vector<EdgeSegment>& detected,
                                      const std::string& channel) {
  const int count = static_cast<int>(folder.frames().size());
  std::vector<FrameResult> results(count);
  const int threads = std::clamp(options.threads, 1, 16);
  std::vector<std::thread> pool;
  for (int w = 0; w < threads; ++w)
    pool.emplace_back([&, w] {
      for (int i = w; i < count && !is_cancelled(options.cancel); i += threads)
        results[i] = measure_frame(folder, i, options, detected, channel);
    });
  for (auto& th : pool) th.join();
  if (Status s = check_not_cancelled(options.cancel, "analysis"); !s) return s.error();

  DefocusReport report;
  report.channel = channel;
  report.acceptable_coc_px = options.acceptable_coc_px;
  std::map<std::string, size_t> by_name;
  std::set<double> f_numbers, positions;
  double focus_distance_mm = 0;
  for (int i = 0; i < count; ++i) {
    const FrameResult& fr = results[i];
    if (!fr.status) return fr.status.error();
    report.pixel_pitch_um = fr.pitch_um;
    report.focal_mm = fr.focal_mm;
    report.channel_focal_mm = fr.channel_focal_mm;
    if (fr.clip_level_dn && (!report.clip_level_dn || *fr.clip_level_dn < *report.clip_level_dn))
      report.clip_level_dn = fr.clip_level_dn;
    report.baseline_sigma_px = fr.baseline;
    for (size_t e = 0; e < fr.edges.size(); ++e) {
      const FrameEdge& fe = fr.edges[e];
      auto [it, inserted] = by_name.emplace(fe.edge.name, report.targets.size());
      if (inserted) {
        report.targets.push_back({});
        report.targets.back().name = fe.edge.name;
        report.targets.back().distance_m = fr.distances[e];
      }
      report.targets[it->second].frames.push_back(fe);
      f_numbers.insert(fe.f_number);
      positions.insert(fe.focus_position);
    }
    auto side = folder.load_sidecar(i);
    if (side && side->settings.contains("focus_distance_m")) {
      const json& d = side->settings["focus_distance_m"];
      focus_distance_mm = d.is_number() ? d.get<double>() * 1e3 : optics::kInfinity;
    }
  }
  report.sweep = f_numbers.size() > 1 && positions.size() <= 1   ? "f_number"
                 : positions.size() > 1 && f_numbers.size() <= 1 ? "focus_position"
                 : f_numbers.size() > 1                          ? "mixed"
                                                                 : "none";
  report.focus_distance_mm = focus_distance_mm;
  for (TargetDefocus& t : report.targets) {
    if (report.sweep == "f_number") fit_aperture(&t, report, options, focus_distance_mm);
    if (report.sweep == "focus_position") fit_focus(&t, report, options);
  }
  return report;
}

}  // namespace

Result<DefocusReport> analyze_defocus(const std::filesystem::path& capture_dir,
                                      const DefocusOptions& options) {
  image::CaptureFolder folder;
  CAMLAB_ASSIGN(folder, image::CaptureFolder::open(capture_dir));
  if (folder.frames().empty()) return make_error("no_frames", "the capture folder holds no frames");
  image::FrameSidecar first;
  CAMLAB_ASSIGN(first, folder.load_sidecar(0));
  std::vector<std::string> channels;
  CAMLAB_ASSIGN(channels, measurable_channels(image::light_sidecar(first)));
  std::vector<EdgeSegment> detected;
  CAMLAB_ASSIGN(detected, detect_edges(folder, options));
  if (channels.size() == 1) return analyze_channel(folder, options, detected, channels[0]);
  // Colour: each channel measured and fitted on its own, then compared.
  DefocusReport report;
  report.acceptable_coc_px = options.acceptable_coc_px;
  for (const std::string& channel : channels) {
    DefocusReport one;
    CAMLAB_ASSIGN(one, analyze_channel(folder, options, detected, channel));
    report.sweep = one.sweep;
    report.pixel_pitch_um = one.pixel_pitch_um;
    report.focal_mm = one.focal_mm;
    report.baseline_sigma_px = one.baseline_sigma_px;
    report.channels.push_back(std::move(one));
  }
  report.chromatic = longitudinal_chromatic_aberration(report.channels);
  return report;
}

namespace {

json targets_json(const DefocusReport& r) {
  json targets = json::array();
  for (const TargetDefocus& t : r.targets) {
    json frames = json::array();
    for (size_t i = 0; i < t.frames.size(); ++i) {
      const FrameEdge& fe = t.frames[i];
      const EdgeMeasurement& m = fe.edge;
      // A diameter only where the status gives one: a measurement, an edge in focus within
      // the baseline (0, bounded by ci95[1]), or one below the diffraction floor (what the
      // pixels show). Rejected edges have none: null, never a 0 that reads as sharp.
      const bool has_diameter =
          m.measured() || m.status == kEdgeAtBaseline || m.status == kEdgeBelowDiffraction;
      json f = {{"frame", fe.frame},
                {"f_number", fe.f_number},
                {"focus_position", fe.focus_position},
                {"status", m.status},
                {"diameter_px", has_diameter ? num(m.diameter_px) : json(nullptr)},
                {"diameter_sigma_px", has_diameter ? num(m.diameter_sigma_px) : json(nullptr)},
                {"ci95_px", has_diameter ? json::array({num(m.ci_low_px), m.upper_unconstrained()
                                                                              ? json(nullptr)
                                                                              : num(m.ci_high_px)})
                                         : json(nullptr)},
                {"apparent_diameter_px", num(m.apparent_diameter_px)},
                {"rms_residual", num(m.rms_residual)},
                {"contrast_to_noise", num(m.contrast_to_noise)},
                {"window_px", {num(2 * m.half_length_px), num(2 * m.half_width_px)}}};
      if (!m.message.empty()) f["message"] = m.message;
      if (m.low_signal) f["low_signal"] = true;  // CNR under 10: sigma includes a 1% bias
      if (m.fit.samples > 0)  // where the fit put the edge: a point on it and its direction
        f["edge_px"] = {{"x", num(m.fit.line.x_px)},
                        {"y", num(m.fit.line.y_px)},
                        {"angle_deg", num(m.fit.line.angle_rad * 180.0 / std::numbers::pi)}};
      if (!m.joint_with.empty()) {
        f["joint_fit_with"] = m.joint_with;  // fitted together with this overlapping neighbour
        f["joint_separation_px"] = m.joint_separation_px;
      }
      if (fe.truth_coc_px) f["truth_coc_px"] = *fe.truth_coc_px;
      if (t.aperture && t.aperture->used[i]) f["cn_deviation"] = t.aperture->cn_deviation[i];
      frames.push_back(f);
    }
    json jt = {{"name", t.name}, {"frames", frames}};
    if (t.distance_m) jt["distance_m"] = *t.distance_m;
    if (t.aperture) {
      jt["coc_vs_aperture"] = {{"k_px", t.aperture->k_px},
                               {"k_sigma_px", t.aperture->k_sigma_px},
                               {"chi2_per_dof", t.aperture->chi2_per_dof},
                               {"frames_used", t.aperture->used_count},
                               {"max_abs_cn_deviation", t.aperture->max_abs_cn_deviation},
                               {"implied_defocus", t.implied_defocus},
                               {"implied_defocus_sigma", t.implied_defocus_sigma}};
      if (t.thin_lens_k_px) {
        jt["coc_vs_aperture"]["thin_lens_k_px"] = *t.thin_lens_k_px;
        jt["coc_vs_aperture"]["k_relative_to_thin_lens"] = t.aperture->k_px / *t.thin_lens_k_px - 1;
      }
    } else if (!t.aperture_error.empty()) {
      jt["coc_vs_aperture"] = {{"error", t.aperture_error}};
    }
    if (t.v_curve) {
      json v = {{"best_position", t.v_curve->best_position},
                {"best_position_sigma", t.v_curve->best_position_sigma},
                {"slope_px_per_step", t.v_curve->slope_px_per_step},
                {"slope_sigma", t.v_curve->slope_sigma},
                {"chi2_per_dof", t.v_curve->chi2_per_dof},
                {"frames_used", t.v_curve->used_count},
                {"minimum_outside_sweep", t.v_curve->p0_at_end},
                {"depth_of_focus_steps", t.depth_of_focus_steps}};
      if (t.aperture_over_zi) v["aperture_over_zi"] = *t.aperture_over_zi;
      if (t.best_lens_to_sensor_mm) v["best_lens_to_sensor_mm"] = *t.best_lens_to_sensor_mm;
      if (t.best_focus_distance_m) v["best_focus_distance_m"] = num(*t.best_focus_distance_m);
      if (t.dof_near_m) v["dof_near_m"] = num(*t.dof_near_m);
      if (t.dof_far_m) v["dof_far_m"] = num(*t.dof_far_m);  // null: infinity
      jt["coc_vs_focus"] = v;
    } else if (!t.v_curve_error.empty()) {
      jt["coc_vs_focus"] = {{"error", t.v_curve_error}};
    }
    targets.push_back(jt);
  }
  return targets;
}

json chromatic_json(const ChromaticFocusShift& c) {
  json j = {{"target", c.target},
            {"method", c.method},
            {"image_distance_mm",
             {{"R", c.image_distance_mm[0]},
              {"G", c.image_distance_mm[1]},
              {"B", c.image_distance_mm[2]}}},
            {"shift_r_mm", num(c.shift_r_mm)},
            {"shift_r_sigma_mm", num(c.shift_r_sigma_mm)},
            {"shift_b_mm", num(c.shift_b_mm)},
            {"shift_b_sigma_mm", num(c.shift_b_sigma_mm)},
            {"side_assumed", c.side_assumed}};
  if (!c.warning.empty()) j["warning"] = c.warning;
  return j;
}

}  // namespace

json to_json(const DefocusReport& r) {
  json out = {{"kind", "defocus"},
              {"sweep", r.sweep},
              {"pixel_pitch_um", r.pixel_pitch_um},
              {"focal_mm", r.focal_mm},
              {"baseline_sigma_px", r.baseline_sigma_px},
              {"acceptable_coc_px", r.acceptable_coc_px}};
  if (r.clip_level_dn) out["clip_level_dn"] = *r.clip_level_dn;
  if (r.channels.empty()) {
    out["targets"] = targets_json(r);
    return out;
  }
  // Colour: per channel, diameters in sensor pixels; then the focus shift between them.
  json channels = json::object();
  for (const DefocusReport& c : r.channels)
    channels[c.channel] = {{"focal_mm", c.channel_focal_mm > 0 ? c.channel_focal_mm : c.focal_mm},
                           {"targets", targets_json(c)}};
  out["channels"] = channels;
  json shifts = json::array();
  for (const ChromaticFocusShift& c : r.chromatic) shifts.push_back(chromatic_json(c));
  out["longitudinal_chromatic_aberration"] = shifts;
  return out;
}

}  // namespace camlab::analysis
