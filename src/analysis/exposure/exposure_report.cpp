// Capture-folder exposure analysis: grouping, pairs, linearity, photon transfer, HDR.
#include "analysis/exposure/exposure_report.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>

#include "analysis/channel_signal.h"
#include "analysis/clip_level.h"
#include "base/cancel.h"
#include "base/format.h"
#include "image/capture_folder.h"

namespace camlab::analysis {
namespace {

using nlohmann::json;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// A setting whose frames have more of the ROI at the clip level than this is saturated:
// above any hot pixel or noise tail (0.1% of a 320 x 240 ROI is 77 pixels).
constexpr double kSaturatedFraction = 0.001;

std::string setting_name(double exposure_us, double gain) {
  return format_significant(exposure_us, 6) + " us x gain " + format_significant(gain, 4);
}

double spec_number(const json& j, const char* section, const char* key, double fallback) {
  if (!j.is_object() || !j.contains(section) || !j[section].is_object()) return fallback;
  const json& s = j[section];
  return s.contains(key) && s[key].is_number() ? s[key].get<double>() : fallback;
}

Result<ExposureReport> analyze_channel(const image::CaptureFolder& folder,
                                       const ExposureOptions& options, const std::string& channel) {
  ExposureReport report;
  report.channel = channel;
  report.frame_count = static_cast<int>(folder.frames().size());

  // Group by setting; keep up to two frames per group (the pair).
  struct Group {
    double exposure_us, gain;
    std::vector<cv::Mat> frames;
    int black = 0, white = 255;
    std::optional<double> clip_level_dn;  // a pile-up at the top of the first frame
  };
  std::optional<double> clip_mean_dn;  // where the frames clip (the lowest plateau's mean)
  std::map<std::pair<double, double>, Group> groups;
  for (int i = 0; i < report.frame_count; ++i) {
    if (Status s = check_not_cancelled(options.cancel, "analysis"); !s) return s.error();
    image::FrameSidecar side;
    CAMLAB_ASSIGN(side, folder.load_sidecar(i));
    const double t = side.settings.value("exposure_us", 0.0), g = side.settings.value("gain", 1.0);
    if (!(t > 0) || !(g > 0))
      return make_error(
          "missing_settings",
          "frame " + std::to_string(i) + " has no positive exposure_us and gain in its settings");
    Group& grp =
        groups.try_emplace({t, g}, Group{t, g, {}, side.black_level_dn, side.white_level_dn})
            .first->second;
    if (grp.frames.size() >= 2) continue;
    cv::Mat stored, samples;
    CAMLAB_ASSIGN(stored, folder.load_stored_image(i));
    CAMLAB_ASSIGN(samples, channel_samples(stored, side, channel));
    grp.frames.push_back(samples);
  }
  const json camera = folder.manifest().contains("source")
                          ? folder.manifest()["source"].value("camera_spec", json::object())
                          : json::object();

  // Statistics over the central region.
  const cv::Mat& first = groups.begin()->second.frames[0];
  const int w = std::max(2, static_cast<int>(first.cols * options.roi_fraction));
  const int h = std::max(2, static_cast<int>(first.rows * options.roi_fraction));
  const cv::Rect roi((first.cols - w) / 2, (first.rows - h) / 2, w, h);
  std::vector<PairStats> pairs;
  std::vector<LinearityPoint> lin_points;
  double max_dn = 0;
  double gain_sum = 0;
  // Where the frames clip (raw DN): the lowest plateau any frame shows (a full well under
  // the ADC's top code, clip_level.h), else each frame's white level.
  for (auto& [key, grp] : groups)
    if (auto plateau = detect_clip_plateau(grp.frames[0], grp.black)) {
      grp.clip_level_dn = plateau->level_dn;
      clip_mean_dn = std::min(clip_mean_dn.value_or(plateau->mean_dn), plateau->mean_dn);
      report.clip_level_dn =
          std::min(report.clip_level_dn.value_or(plateau->level_dn), plateau->level_dn);
    }
  const auto clipped_fraction = [&](const Group& grp) {
    const double level = std::min<double>(report.clip_level_dn.value_or(grp.white), grp.white);
    double worst = 0;
    for (const cv::Mat& f : grp.frames) {
      cv::Mat at_clip;
      cv::compare(f(roi), level, at_clip, cv::CMP_GE);
      worst = std::max(worst, cv::countNonZero(at_clip) / static_cast<double>(roi.area()));
    }
    return worst;
  };
  bool any_saturated = false;
  for (auto& [key, grp] : groups) {
    max_dn = grp.white - grp.black;
    gain_sum += grp.gain;
    LinearityPoint lp;
    lp.exposure_gain_us = grp.exposure_us * grp.gain;
    double mean = 0;
    for (const cv::Mat& f : grp.frames) mean += cv::mean(f(roi))[0] - grp.black;
    lp.mean_dn = mean / static_cast<double>(grp.frames.size());
    // A setting with part of the ROI clipped (a bright area of the scene at the clip while
    // the rest is not): its mean and variance are not the sensor's response, whatever its
    // mean says. Left out of every fit, and named (the README's bracket clipped at 16 ms
    // on the bright side of its edges and gave K 56% low with a tight error bar).
    const double clipped = clipped_fraction(grp);
    lp.saturated = clipped > kSaturatedFraction;
    any_saturated |= lp.saturated;
    if (lp.saturated)
      report.left_out.push_back(setting_name(grp.exposure_us, grp.gain) + ": saturated, " +
                                format_significant(100 * clipped, 3) +
                                "% of the ROI at the clip level");
    lin_points.push_back(lp);
    if (grp.frames.size() == 2) {
      auto ps = pair_stats(grp.frames[0], grp.frames[1], grp.black, roi);
      if (!ps) return ps.error();
      ps->exposure_us = grp.exposure_us;
      ps->gain = grp.gain;
      ps->saturated = lp.saturated;
      ps->clipped_fraction = clipped;
      pairs.push_back(*ps);
    }
  }
  // Where a setting clipped at the white level without a plateau (no shot noise to tell
  // it), the white level is the clip: the saturation mean is there.
  if (any_saturated && !clip_mean_dn) clip_mean_dn = groups.begin()->second.white;
  const double mean_gain = gain_sum / static_cast<double>(groups.size());

  // Expected K from the spec.
  const double full_well = spec_number(camera, "sensor", "full_well_e", 0);
  double k0 = spec_number(camera, "sensor", "conversion_gain_dn_per_e", 0);
  if (k0 <= 0 && full_well > 0) k0 = max_dn / full_well;

  if (pairs.size() >= 3) {
    std::optional<double> clip_mean;
    if (clip_mean_dn) clip_mean = *clip_mean_dn - groups.begin()->second.black;
    auto pt = fit_photon_transfer(pairs, clip_mean);
    if (pt) {
      report.photon_transfer = *pt;
      if (k0 > 0) report.photon_transfer->expected_gain_dn_per_e = k0 * mean_gain;
    } else {
      report.photon_transfer_error = pt.error().text();
    }
  } else {
    report.photon_transfer_error =
        "too_few_samples: photon transfer needs frame pairs "
        "(--repeats 2) at 3 or more settings";
  }

  const double saturation =
      report.photon_transfer
          ? report.photon_transfer->saturation_mean_dn
          : (k0 > 0 && full_well > 0 ? std::min(max_dn, k0 * full_well * mean_gain) : max_dn);
  // Frames that clip below their white level clip the linearity too.
  const double clip_saturation =
      report.clip_level_dn ? *report.clip_level_dn - groups.begin()->second.black : saturation;
  // Saturation is known from the data (reached, or a clip seen) or from the spec; a
  // photon transfer that never reached it gives only a lower bound.
  const bool saturation_known = !report.photon_transfer ||
                                report.photon_transfer->saturation_reached ||
                                report.clip_level_dn.has_value();
  auto lin = fit_linearity(lin_points, std::min(saturation, clip_saturation), saturation_known);
  if (lin) {
    report.linearity = lin->points;
    report.linearity_slope_dn_per_us = lin->slope_dn_per_us;
    report.max_linearity_error_pct = lin->max_abs_error_pct;
    report.linearity_used = lin->used_count;
  } else {
    report.linearity = lin_points;
    report.linearity_error = lin.error().text();
  }
  // The rest of what the fits left out, by EMVA 1288's ranges.
  for (const LinearityPoint& p : report.linearity)
    if (!p.saturated && !p.used && lin)
      report.left_out.push_back(
          format_significant(p.exposure_gain_us, 6) + " us (exposure x gain): " +
          (p.mean_dn < 0.5 * std::min(saturation, clip_saturation) ? "dark, below 5%"
                                                                   : "bright, above 95%") +
          " of saturation (left out of the linearity fit only)");
  if (report.photon_transfer)
    for (const PairStats& p : report.photon_transfer->points)
      if (!p.saturated && !p.used)
        report.left_out.push_back(setting_name(p.exposure_us, p.gain) +
                                  ": above 70% of saturation (left out of the photon transfer "
                                  "fit only)");

  // HDR: one frame per setting, noise from the photon transfer (else the spec).
  if (groups.size() >= 2) {
    HdrNoise noise;
    if (report.photon_transfer) {
      noise.k_dn_per_e = report.photon_transfer->system_gain_dn_per_e / mean_gain;
      noise.read_variance_dn2 = report.photon_transfer->dark_variance_dn2 / (mean_gain * mean_gain);
    } else if (k0 > 0) {
      noise.k_dn_per_e = k0;
      const double read_e = spec_number(camera, "sensor", "read_noise_e", 0);
      noise.read_variance_dn2 = k0 * k0 * read_e * read_e;
    }
    std::vector<HdrFrame> frames;
    for (auto& [key, grp] : groups) {
      HdrFrame f;
      grp.frames[0].convertTo(f.signal_dn, CV_32F, 1.0, -grp.black);
      f.exposure_us = grp.exposure_us;
      f.gain = grp.gain;
      f.clip_dn = max_dn;
      if (k0 > 0 && full_well > 0) f.clip_dn = std::min(max_dn, k0 * grp.gain * full_well);
      // A full well below the ADC's top code shows as a pile-up at the top of the frame's
      // histogram (clip_level.h); pixels in it are clipped whatever the white level says.
      // The merge drops pixels above 97% of clip_dn, so clip_dn is set to keep the pile-up
      // above that line.
      if (grp.clip_level_dn)
        f.clip_dn = std::min(f.clip_dn, (*grp.clip_level_dn - grp.black) / 0.97);
      frames.push_back(std::move(f));
    }
    auto hdr = merge_hdr(frames, noise);
    if (hdr)
      report.hdr = std::move(*hdr);
    else
      report.hdr_error = hdr.error().text();
  } else {
    report.hdr_error = "too_few_samples: an HDR merge needs 2 or more exposures";
  }
  return report;
}

}  // namespace

Result<ExposureReport> analyze_exposure(const std::filesystem::path& capture_dir,
                                        const ExposureOptions& options) {
  image::CaptureFolder folder;
  CAMLAB_ASSIGN(folder, image::CaptureFolder::open(capture_dir));
  if (folder.frames().empty()) return make_error("no_frames", "the capture folder holds no frames");
  if (!(options.roi_fraction > 0 && options.roi_fraction <= 1))
    return make_error("invalid_argument", "roi_fraction must be in (0, 1]");
  image::FrameSidecar first;
  CAMLAB_ASSIGN(first, folder.load_sidecar(0));
  std::vector<std::string> channels;
  CAMLAB_ASSIGN(channels, measurable_channels(first));
  if (channels.size() == 1) return analyze_channel(folder, options, channels[0]);
  ExposureReport report;
  report.frame_count = static_cast<int>(folder.frames().size());
  for (const std::string& channel : channels) {
    ExposureReport one;
    CAMLAB_ASSIGN(one, analyze_channel(folder, options, channel));
    report.channels.push_back(std::move(one));
  }
  return report;
}

namespace {

json channel_json(const ExposureReport& r) {
  json j = json::object();
  if (r.clip_level_dn) j["clip_level_dn"] = *r.clip_level_dn;
  json lin = json::array();
  for (const auto& p : r.linearity)
    lin.push_back({{"exposure_gain_us", p.exposure_gain_us},
                   {"mean_dn", p.mean_dn},
                   {"error_pct", p.error_pct},
                   {"used", p.used},
                   {"saturated", p.saturated}});
  j["left_out"] = r.left_out;
  j["linearity"] = {{"points", lin},
                    {"slope_dn_per_us", r.linearity_slope_dn_per_us},
                    {"max_abs_error_pct", r.max_linearity_error_pct},
                    {"used", r.linearity_used}};
  if (!r.linearity_error.empty()) j["linearity"]["error"] = r.linearity_error;
  if (r.photon_transfer) {
    const auto& pt = *r.photon_transfer;
    json pts = json::array();
    for (const auto& p : pt.points)
      pts.push_back({{"exposure_us", p.exposure_us},
                     {"gain", p.gain},
                     {"mean_dn", p.mean_dn},
                     {"variance_dn2", p.variance_dn2},
                     {"used", p.used},
                     {"saturated", p.saturated},
                     {"clipped_fraction", p.clipped_fraction}});
    j["photon_transfer"] = {
        {"system_gain_dn_per_e", pt.system_gain_dn_per_e},
        {"system_gain_sigma", pt.system_gain_sigma},
        {"expected_gain_dn_per_e",
         num(pt.expected_gain_dn_per_e > 0 ? pt.expected_gain_dn_per_e : NAN)},
        {"dark_variance_dn2", pt.dark_variance_dn2},
        {"dark_noise_e", pt.dark_noise_e},
        {"saturation_reached", pt.saturation_reached},
        {"saturation_mean_dn", pt.saturation_mean_dn},
        // Without saturation in the data, the capacity and what follows
        // from it are lower bounds: given under their own names only.
        {"saturation_capacity_e", num(pt.saturation_reached ? pt.saturation_capacity_e : NAN)},
        {"snr_max", num(pt.saturation_reached ? pt.snr_max : NAN)},
        {"dynamic_range", num(pt.saturation_reached ? pt.dynamic_range : NAN)},
        {"pairs_used", pt.used_count},
        {"points", pts}};
    if (!pt.saturation_reached)
      j["photon_transfer"].update({{"saturation_capacity_lower_bound_e", pt.saturation_capacity_e},
                                   {"snr_max_lower_bound", pt.snr_max},
                                   {"dynamic_range_lower_bound", pt.dynamic_range}});
  } else {
    j["photon_transfer"] = {{"error", r.photon_transfer_error}};
  }
  if (r.hdr) {
    double lo = 0, hi = 0;
    cv::minMaxLoc(r.hdr->radiance, &lo, &hi);
    j["hdr"] = {{"clipped_everywhere", r.hdr->clipped_everywhere},
                {"radiance_min_dn_per_us", lo},
                {"radiance_max_dn_per_us", hi}};
    if (r.hdr_median_relative_error)
      j["hdr"]["median_relative_error"] = *r.hdr_median_relative_error;
  } else {
    j["hdr"] = {{"error", r.hdr_error}};
  }
  return j;
}

}  // namespace

json to_json(const ExposureReport& r) {
  json j = {{"kind", "exposure"}, {"frames", r.frame_count}};
  if (r.channels.empty()) {
    j.update(channel_json(r));
    return j;
  }
  json channels = json::object();
  for (const ExposureReport& c : r.channels) channels[c.channel] = channel_json(c);
  j["channels"] = channels;
  return j;
}

}  // namespace camlab::analysis