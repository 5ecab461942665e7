// `camlab analyze` and POST /v1/analyses: dispatch, text summaries (analyze_folder.h).
#include "analysis/analyze_folder.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

#include <opencv2/core.hpp>

#include "analysis/analysis_summary.h"

#include "analysis/capture_check.h"
#include "analysis/focus/focus_report.h"
#include "image/capture_folder.h"

namespace camlab::analysis {
namespace {

std::string line(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string line(const char* format, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, format);
  std::vsnprintf(buf, sizeof buf, format, ap);
  va_end(ap);
  return buf;
}

nlohmann::json with_plots(nlohmann::json report, const std::vector<std::filesystem::path>& plots) {
  if (!plots.empty()) {
    report["plots"] = nlohmann::json::array();
    for (const auto& p : plots) report["plots"].push_back(p.string());
  }
  return report;
}

}  // namespace

namespace {

std::string defocus_text(const DefocusReport& r) {
  std::string text =
      line("defocus: %zu target(s), sweep %s, pitch %.3g um, f %.4g mm, baseline sigma %.3g px\n",
           r.targets.size(), r.sweep.c_str(), r.pixel_pitch_um, r.focal_mm, r.baseline_sigma_px);
  for (const auto& t : r.targets) {
    text += line("\n%s", t.name.c_str());
    if (t.distance_m) text += line(" (at %.4g m)", *t.distance_m);
    text += "\n  frame      N   focus  status                    D [px]  95% CI          truth\n";
    for (const auto& fe : t.frames) {
      const auto& m = fe.edge;
      text += line("  %5d %6.3g %7.1f  %-24s %7.3f  [%6.3f, %s]", fe.frame, fe.f_number,
                   fe.focus_position, m.status.c_str(), m.diameter_px, m.ci_low_px,
                   m.upper_unconstrained() ? "unconstrained" : line("%6.3f", m.ci_high_px).c_str());
      text += fe.truth_coc_px ? line("  %7.3f", *fe.truth_coc_px) : std::string();
      if (m.low_signal) text += line("  LOW SIGNAL (CNR %.1f)", m.contrast_to_noise);
      text += m.joint_with.empty() ? std::string("\n")
                                   : "  (fitted jointly with " + m.joint_with + ")\n";
    }
    if (t.aperture) {
      text +=
          line("  C x N = k = %.4f +- %.4f px (%d frames, chi2/dof %.2f, max |CN/k - 1| %.2f%%)\n",
               t.aperture->k_px, t.aperture->k_sigma_px, t.aperture->used_count,
               t.aperture->chi2_per_dof, 100 * t.aperture->max_abs_cn_deviation);
      text += line("  implied defocus |z_s - z_i| / z_i = %.5f +- %.5f\n", t.implied_defocus,
                   t.implied_defocus_sigma);
      if (t.thin_lens_k_px)
        text += line("  thin lens predicts k = %.4f px (measured/predicted - 1 = %+.2f%%)\n",
                     *t.thin_lens_k_px, 100 * (t.aperture->k_px / *t.thin_lens_k_px - 1));
    } else if (!t.aperture_error.empty()) {
      text += "  C = k/N: " + t.aperture_error + "\n";
    }
    if (t.v_curve) {
      text += line(
          "  V-curve: best focus %.3f +- %.3f steps, slope %.5f +- %.5f px/step (%d frames%s)\n",
          t.v_curve->best_position, t.v_curve->best_position_sigma, t.v_curve->slope_px_per_step,
          t.v_curve->slope_sigma, t.v_curve->used_count,
          t.v_curve->p0_at_end ? ", MINIMUM OUTSIDE THE SWEEP: extrapolated" : "");
      if (t.aperture_over_zi) text += line("  slope A / z_i = %.5f\n", *t.aperture_over_zi);
      if (t.best_focus_distance_m)
        text += line("  in best focus: object at %.4g m (lens-to-sensor %.5f mm)\n",
                     *t.best_focus_distance_m, *t.best_lens_to_sensor_mm);
      if (t.dof_near_m && t.dof_far_m)
        text +=
            line("  depth of field for CoC %.3g px: %.4g m .. %s m (depth of focus %.1f steps)\n",
                 r.acceptable_coc_px, *t.dof_near_m,
                 std::isfinite(*t.dof_far_m) ? line("%.4g", *t.dof_far_m).c_str() : "infinity",
                 t.depth_of_focus_steps);
    } else if (!t.v_curve_error.empty()) {
      text += "  V-curve: " + t.v_curve_error + "\n";
    }
  }
  return text;
}

}  // namespace

std::string to_text(const DefocusReport& r) {
  if (r.channels.empty()) return defocus_text(r);
  std::string text =
      line("defocus of a colour capture: each channel on its own sites, in sensor px\n");
  for (const DefocusReport& c : r.channels)
    text += "\n== channel " + c.channel + " ==\n" + defocus_text(c);
  if (!r.chromatic.empty())
    text += "\nlongitudinal chromatic aberration (mm at the sensor, + = farther from the lens):\n";
  for (const ChromaticFocusShift& c : r.chromatic) {
    text += line("  %s (%s): R %+.5f +- %.5f, B %+.5f +- %.5f%s\n", c.target.c_str(),
                 c.method.c_str(), c.shift_r_mm, c.shift_r_sigma_mm, c.shift_b_mm,
                 c.shift_b_sigma_mm, c.side_assumed ? " (side of the sensor assumed)" : "");
    if (!c.warning.empty()) text += "    warning: " + c.warning + "\n";
  }
  return text;
}

namespace {

std::string exposure_text(const ExposureReport& r) {
  std::string text =
      line("exposure: %d frames, %zu exposure settings\n", r.frame_count, r.linearity.size());
  if (!r.linearity.empty()) {
    text += "  T x gain [us]   mean [DN]   linearity error\n";
    for (const auto& l : r.linearity)
      text += line("  %12.1f %11.2f %+9.3f%%%s\n", l.exposure_gain_us, l.mean_dn, l.error_pct,
                   l.saturated ? "  (saturated: not used)"
                   : l.used    ? ""
                               : "  (outside 5-95% of saturation: not used)");
    text += line("  max linearity error %.3f%% over %d settings\n", r.max_linearity_error_pct,
                 r.linearity_used);
  }
  if (r.photon_transfer) {
    const auto& pt = *r.photon_transfer;
    text += line("  photon transfer (EMVA 1288, %d pairs, %d in the fit):\n",
                 static_cast<int>(pt.points.size()), pt.used_count);
    text += line("    system gain K     %.5f +- %.5f DN/e-\n", pt.system_gain_dn_per_e,
                 pt.system_gain_sigma);
    text += line("    dark noise        %.3f e-\n", pt.dark_noise_e);
    // Without saturation in the data these are bounds, said as such.
    const char* at_least = pt.saturation_reached ? "" : ">= ";
    text += line("    saturation        %s%.0f e- (mean %.1f DN above dark)%s\n", at_least,
                 pt.saturation_capacity_e, pt.saturation_mean_dn - pt.dark_mean_dn,
                 pt.saturation_reached ? "" : ": a lower bound, no setting reached saturation");
    text += line("    SNR max           %s%.2f (%.2f dB)\n", at_least, pt.snr_max,
                 20 * std::log10(pt.snr_max));
    text += line("    dynamic range     %s%.1f (%.2f dB)\n", at_least, pt.dynamic_range,
                 20 * std::log10(pt.dynamic_range));
    if (pt.expected_gain_dn_per_e > 0)
      text += line("    spec K x gain     %.5f DN/e- (measured/spec - 1 = %+.2f%%)\n",
                   pt.expected_gain_dn_per_e,
                   100 * (pt.system_gain_dn_per_e / pt.expected_gain_dn_per_e - 1));
  } else if (!r.photon_transfer_error.empty()) {
    text += "  photon transfer: " + r.photon_transfer_error + "\n";
  }
  for (const std::string& why : r.left_out) text += "  left out: " + why + "\n";
  if (r.hdr) {
    text += line(
        "  HDR merge: %zu exposures, %lld pixels clipped in every frame (flagged, lower bound "
        "given)\n",
        r.linearity.size(), static_cast<long long>(r.hdr->clipped_everywhere));
    if (r.hdr_median_relative_error)
      text +=
          line("    median radiance error vs truth %.3f%%\n", 100 * *r.hdr_median_relative_error);
  } else if (!r.hdr_error.empty()) {
    text += "  HDR merge: " + r.hdr_error + "\n";
  }
  return text;
}

}  // namespace

std::string to_text(const ExposureReport& r) {
  if (r.channels.empty()) return exposure_text(r);
  std::string text = line("exposure of a colour capture: each channel on its own samples\n");
  for (const ExposureReport& c : r.channels)
    text += "\n== channel " + c.channel + " ==\n" + exposure_text(c);
  text += "\nsummary       K [DN/e-]   read noise [e-]   full well [e-]   max |linearity error|\n";
  for (const ExposureReport& c : r.channels) {
    text += line("  %-10s", c.channel.c_str());
    if (c.photon_transfer)
      text += line(" %9.4f   %15.2f   %14.0f", c.photon_transfer->system_gain_dn_per_e,
                   c.photon_transfer->dark_noise_e, c.photon_transfer->saturation_capacity_e);
    else
      text += line(" %9s   %15s   %14s", "-", "-", "-");
    text += line("   %.3f%%\n", c.max_linearity_error_pct);
  }
  return text;
}

namespace {

std::string focus_text(const FocusReport& r, int region_px) {
  int ok = 0, flat = 0, end = 0;
  for (const auto& rr : r.regions) {
    ok += rr.focus.status == kFocusOk;
    flat += rr.focus.status == kFocusFlat;
    end += rr.focus.status == kFocusPeakAtEnd;
  }
  std::string text = line(
      "focus stack: %zu positions (%g..%g), %zu regions of %d px: %d ok, %d flat, %d peak at an "
      "end\n",
      r.positions.size(), r.positions.front(), r.positions.back(), r.regions.size(), region_px, ok,
      flat, end);
  text += "  region (x,y)     status         best position  sigma [steps]  distance [m]\n";
  for (const auto& rr : r.regions) {
    const double step = r.positions.size() > 1
                            ? (r.positions.back() - r.positions.front()) / (r.positions.size() - 1)
                            : 0;
    text += line("  (%4d,%4d)  %-14s %12.3f %12.3f", rr.focus.rect.x, rr.focus.rect.y,
                 rr.focus.status.c_str(), rr.best_position, rr.focus.best_index_sigma * step);
    text += rr.distance_m ? (std::isfinite(*rr.distance_m) ? line("  %10.4f\n", *rr.distance_m)
                                                           : std::string("    infinity\n"))
                          : std::string("\n");
  }
  text += line("  depth map: %.1f%% of pixels valid\n",
               100.0 * cv::countNonZero(r.valid) / double(r.valid.total()));
  return text;
}

}  // namespace

std::string to_text(const FocusReport& r, int region_px) {
  if (r.channels.empty()) return focus_text(r, region_px);
  std::string text = "luminance of a colour capture:\n" + focus_text(r, region_px);
  text += "\nper channel (one sample plane each; regions of " + std::to_string(region_px) +
          " plane px):\n  channel  regions ok  median best position\n";
  for (const FocusReport& c : r.channels) {
    std::vector<double> best;
    for (const auto& rr : c.regions)
      if (rr.focus.status == kFocusOk) best.push_back(rr.best_position);
    std::sort(best.begin(), best.end());
    text += line("  %-7s  %10zu", c.channel.c_str(), best.size());
    text += best.empty() ? std::string("  -\n") : line("  %19.3f\n", best[best.size() / 2]);
  }
  return text;
}

Result<AnalysisRun> analyze(std::string_view kind, const std::filesystem::path& dir,
                            const AnalyzeOptions& options) {
  AnalysisRun run;
  // One measurement: its report, its text, its plots when asked for.
  // Each ends with its summary: what it measured, what it left out and why.
  auto finish = [&](const auto& report, std::string text, auto write_plots) -> Status {
    const nlohmann::json summary = summary_json(report);
    run.text = std::move(text) + summary_text(summary);
    if (!options.plots_dir.empty())
      CAMLAB_ASSIGN(run.plots, write_plots(options.plots_dir, report));
    run.report = with_plots(to_json(report), run.plots);
    run.report["summary"] = summary;
    return {};
  };
  if (kind != "defocus" && kind != "exposure" && kind != "focus" && kind != "sfr" &&
      kind != "lensmap")
    return make_error("invalid_argument", "unknown analysis '" + std::string(kind) +
                                              "'; use defocus, exposure, focus, sfr or lensmap");
  // The capture must be one the analysis can measure (capture_check.h): the wrong one is
  // an error naming what is needed, never an empty report.
  {
    image::CaptureFolder folder;
    CAMLAB_ASSIGN(folder, image::CaptureFolder::open(dir));
    if (Status fits = check_capture_for(kind, folder); !fits) return fits.error();
  }
  Status done;
  // The stop request reaches each measurement's own options.
  DefocusOptions defocus = options.defocus;
  ExposureOptions exposure = options.exposure;
  FocusStackOptions focus = options.focus;
  defocus.cancel = exposure.cancel = focus.cancel = options.cancel;
  if (kind == "defocus") {
    DefocusReport r;
    CAMLAB_ASSIGN(r, analyze_defocus(dir, defocus));
    done = finish(r, to_text(r), write_defocus_plots);
  } else if (kind == "exposure") {
    ExposureReport r;
    CAMLAB_ASSIGN(r, analyze_exposure(dir, exposure));
    done = finish(r, to_text(r), write_exposure_plots);
  } else if (kind == "focus") {
    FocusReport r;
    CAMLAB_ASSIGN(r, analyze_focus(dir, focus));
    done = finish(r, to_text(r, options.focus.region_px), write_focus_plots);
  } else if (kind == "sfr") {
    // Its report carries its own summary (measured, left out and why); no plots.
    SfrImageReport r;
    CAMLAB_ASSIGN(r, analyze_sfr_folder(dir, options.sfr));
    run.report = std::move(r.report);
    run.report["kind"] = "sfr";
    run.text = std::move(r.text);
  } else if (kind == "lensmap") {
    LensMapOptions lensmap = options.lensmap;
    lensmap.sfr = options.sfr;
    LensMapReport r;
    CAMLAB_ASSIGN(r, analyze_lens_map(dir, lensmap));
    if (!options.plots_dir.empty())
      CAMLAB_ASSIGN(run.plots, write_lens_map_plots(options.plots_dir, r.report));
    run.report = with_plots(std::move(r.report), run.plots);
    run.report["kind"] = "lensmap";
    run.text = std::move(r.text) + summary_text(run.report["summary"]);
  } else {
    return make_error("invalid_argument", "unknown analysis '" + std::string(kind) +
                                              "'; use defocus, exposure, focus, sfr or lensmap");
  }
  if (!done) return done.error();
  // Every summary carries its own text, for pages that show it as the CLI prints it.
  if (run.report.contains("summary")) {
    std::string text = summary_text(run.report["summary"]);
    while (!text.empty() && text.back() == '\n') text.pop_back();
    run.report["summary"]["text"] = text;
  }
  // A capture cut short (camlabd stopped, the camera vanished) is still read, but never
  // silently: its numbers come from the frames that made it to disk.
  auto folder = image::CaptureFolder::open(dir);
  if (folder && !folder->complete()) {
    const std::string warning = "the capture is incomplete (manifest says complete: false): " +
                                std::to_string(folder->frames().size()) +
                                " frames were written before it stopped; results use those only";
    run.report["warnings"].push_back(warning);
    run.text = "warning: " + warning + "\n" + run.text;
  }
  return run;
}

Result<nlohmann::json> analyze_folder(std::string_view kind, const std::filesystem::path& dir,
                                      const AnalyzeOptions& options) {
  AnalysisRun run;
  CAMLAB_ASSIGN(run, analyze(kind, dir, options));
  return std::move(run.report);
}

}  // namespace camlab::analysis
