// `camlab analyze defocus|exposure|focus DIR`: measurements on a capture folder (src/analysis),
// printed as a text summary or JSON, optionally written as a JSON report and PNG plots.
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <memory>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/defocus_report.h"
#include "analysis/exposure_report.h"
#include "analysis/focus_report.h"
#include "analysis/plot.h"
#include "commands.h"

namespace camlab::cli {
namespace {

struct AnalyzeArgs {
  std::string dir;
  bool json = false;
  std::string report_path;
  std::string plots_dir;
  double baseline_sigma_px = -1;
  double min_diameter_px = 1.0;
  double acceptable_coc_px = 2.0;
  int threads = 2;
  int region_px = 32;
  int window_px = 9;
};

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "camlab analyze: %s\n", message.c_str());
  throw CLI::RuntimeError(2);
}

void emit(const AnalyzeArgs& args, const nlohmann::json& report, const std::string& text) {
  if (!args.report_path.empty()) {
    std::ofstream out(args.report_path);
    out << report.dump(2) << "\n";
    if (!out) fail("cannot write the report to " + args.report_path);
  }
  if (args.json)
    std::printf("%s\n", report.dump(2).c_str());
  else
    std::printf("%s", text.c_str());
}

std::filesystem::path plots_dir(const AnalyzeArgs& args) {
  std::error_code ec;
  std::filesystem::create_directories(args.plots_dir, ec);
  if (ec) fail("cannot create " + args.plots_dir + ": " + ec.message());
  return args.plots_dir;
}

void check(const Status& s) {
  if (!s) fail(s.error().message);
}

std::string line(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string line(const char* format, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, format);
  std::vsnprintf(buf, sizeof buf, format, ap);
  va_end(ap);
  return buf;
}

void plot_defocus(const AnalyzeArgs& args, const analysis::DefocusReport& r) {
  const auto dir = plots_dir(args);
  for (const analysis::TargetDefocus& t : r.targets) {
    analysis::PlotSpec spec;
    analysis::PlotSeries measured{"measured (+-1 sigma)", {}, {}, {}, false, 0xc00000};
    analysis::PlotSeries fit{"", {}, {}, {}, true, 0x0000c0};
    const bool aperture = r.sweep == "f_number";
    for (const auto& fe : t.frames) {
      if (!fe.edge.measured()) continue;
      measured.x.push_back(aperture ? fe.f_number : fe.focus_position);
      measured.y.push_back(fe.edge.diameter_px);
      measured.y_error.push_back(fe.edge.diameter_sigma_px);
    }
    if (aperture && t.aperture) {
      spec.title = t.name + ": CoC vs f-number";
      spec.x_label = "f-number N";
      fit.label = line("fit C = %.3f / N", t.aperture->k_px);
      for (double n = measured.x.empty() ? 1 : *std::min_element(measured.x.begin(), measured.x.end());
           !measured.x.empty() && n <= *std::max_element(measured.x.begin(), measured.x.end()) * 1.001;
           n *= 1.02) {
        fit.x.push_back(n);
        fit.y.push_back(t.aperture->k_px / n);
      }
    } else if (!aperture && t.v_curve) {
      spec.title = t.name + ": V-curve";
      spec.x_label = "focus position (steps)";
      fit.label = line("fit: best %.2f, slope %.4f px/step", t.v_curve->best_position,
                       t.v_curve->slope_px_per_step);
      double lo = 1e300, hi = -1e300;
      for (const auto& fe : t.frames) {
        lo = std::min(lo, fe.focus_position);
        hi = std::max(hi, fe.focus_position);
      }
      for (double p : {lo, t.v_curve->best_position, hi}) {
        fit.x.push_back(p);
        fit.y.push_back(t.v_curve->slope_px_per_step * std::fabs(p - t.v_curve->best_position));
      }
    } else {
      continue;
    }
    spec.y_label = "blur diameter (px)";
    spec.series = {measured, fit};
    check(analysis::write_plot(dir / (t.name + (aperture ? "_coc_vs_n.png" : "_v_curve.png")), spec));
  }
}

void run_defocus(const AnalyzeArgs& args) {
  analysis::DefocusOptions options;
  options.baseline_sigma_px = args.baseline_sigma_px;
  options.min_diameter_px = args.min_diameter_px;
  options.acceptable_coc_px = args.acceptable_coc_px;
  options.threads = args.threads;
  auto report = analysis::analyze_defocus(args.dir, options);
  if (!report) fail(report.error().message);
  const analysis::DefocusReport& r = *report;
  std::string text = line("defocus: %zu target(s), sweep %s, pitch %.3g um, f %.4g mm, baseline sigma %.3g px\n",
                          r.targets.size(), r.sweep.c_str(), r.pixel_pitch_um, r.focal_mm,
                          r.baseline_sigma_px);
  for (const auto& t : r.targets) {
    text += line("\n%s", t.name.c_str());
    if (t.distance_m) text += line(" (at %.4g m)", *t.distance_m);
    text += "\n  frame      N   focus  status                    D [px]  95% CI          truth\n";
    for (const auto& fe : t.frames) {
      const auto& m = fe.edge;
      text += line("  %5d %6.3g %7.1f  %-24s %7.3f  [%6.3f, %6.3f]", fe.frame, fe.f_number,
                   fe.focus_position, m.status.c_str(), m.diameter_px, m.ci_low_px, m.ci_high_px);
      text += fe.truth_coc_px ? line("  %7.3f\n", *fe.truth_coc_px) : std::string("\n");
    }
    if (t.aperture) {
      text += line("  C x N = k = %.4f +- %.4f px (%d frames, chi2/dof %.2f, max |CN/k - 1| %.2f%%)\n",
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
      text += line("  V-curve: best focus %.3f +- %.3f steps, slope %.5f +- %.5f px/step (%d frames%s)\n",
                   t.v_curve->best_position, t.v_curve->best_position_sigma,
                   t.v_curve->slope_px_per_step, t.v_curve->slope_sigma, t.v_curve->used_count,
                   t.v_curve->p0_at_end ? ", MINIMUM OUTSIDE THE SWEEP: extrapolated" : "");
      if (t.aperture_over_zi) text += line("  slope A / z_i = %.5f\n", *t.aperture_over_zi);
      if (t.best_focus_distance_m)
        text += line("  in best focus: object at %.4g m (lens-to-sensor %.5f mm)\n",
                     *t.best_focus_distance_m, *t.best_lens_to_sensor_mm);
      if (t.dof_near_m && t.dof_far_m)
        text += line("  depth of field for CoC %.3g px: %.4g m .. %s m (depth of focus %.1f steps)\n",
                     r.acceptable_coc_px, *t.dof_near_m,
                     std::isfinite(*t.dof_far_m) ? line("%.4g", *t.dof_far_m).c_str() : "infinity",
                     t.depth_of_focus_steps);
    } else if (!t.v_curve_error.empty()) {
      text += "  V-curve: " + t.v_curve_error + "\n";
    }
  }
  if (!args.plots_dir.empty()) plot_defocus(args, r);
  emit(args, analysis::to_json(r), text);
}

void plot_exposure(const AnalyzeArgs& args, const analysis::ExposureReport& r) {
  const auto dir = plots_dir(args);
  if (r.photon_transfer) {
    const auto& pt = *r.photon_transfer;
    analysis::PlotSpec spec{"photon transfer", "mean signal above dark (DN)", "temporal variance (DN^2)",
                            false, false, {}};
    analysis::PlotSeries pts{"frame pairs", {}, {}, {}, false, 0xc00000};
    analysis::PlotSeries used{"used in the fit", {}, {}, {}, false, 0x008000};
    for (const auto& p : pt.points) {
      (p.used ? used : pts).x.push_back(p.mean_dn - pt.dark_mean_dn);
      (p.used ? used : pts).y.push_back(p.variance_dn2);
    }
    analysis::PlotSeries fit{line("K = %.4f DN/e-", pt.system_gain_dn_per_e), {}, {}, {}, true, 0x0000c0};
    for (double m : {0.0, pt.saturation_mean_dn - pt.dark_mean_dn}) {
      fit.x.push_back(m);
      fit.y.push_back(pt.dark_variance_dn2 + pt.system_gain_dn_per_e * m);
    }
    spec.series = {pts, used, fit};
    check(analysis::write_plot(dir / "photon_transfer.png", spec));
  }
  if (!r.linearity.empty()) {
    analysis::PlotSpec spec{"linearity", "exposure x gain (us)", "mean signal above dark (DN)", false, false, {}};
    analysis::PlotSeries pts{"frames", {}, {}, {}, false, 0xc00000};
    analysis::PlotSeries fit{line("max error %.2f%%", r.max_linearity_error_pct), {}, {}, {}, true, 0x0000c0};
    for (const auto& l : r.linearity) {
      pts.x.push_back(l.exposure_gain_us);
      pts.y.push_back(l.mean_dn);
      fit.x.push_back(l.exposure_gain_us);
      fit.y.push_back(r.linearity_slope_dn_per_us * l.exposure_gain_us);
    }
    spec.series = {pts, fit};
    check(analysis::write_plot(dir / "linearity.png", spec));
  }
}

void run_exposure(const AnalyzeArgs& args) {
  analysis::ExposureOptions options;
  auto report = analysis::analyze_exposure(args.dir, options);
  if (!report) fail(report.error().message);
  const analysis::ExposureReport& r = *report;
  std::string text = line("exposure: %d frames, %zu exposure settings\n", r.frame_count, r.linearity.size());
  if (!r.linearity.empty()) {
    text += "  T x gain [us]   mean [DN]   linearity error\n";
    for (const auto& l : r.linearity)
      text += line("  %12.1f %11.2f %+9.3f%%%s\n", l.exposure_gain_us, l.mean_dn, l.error_pct,
                   l.used ? "" : "  (saturated or dark: not used)");
    text += line("  max linearity error %.3f%% over %d settings\n", r.max_linearity_error_pct, r.linearity_used);
  }
  if (r.photon_transfer) {
    const auto& pt = *r.photon_transfer;
    text += line("  photon transfer (EMVA 1288, %d pairs, %d in the fit):\n", static_cast<int>(pt.points.size()), pt.used_count);
    text += line("    system gain K     %.5f +- %.5f DN/e-\n", pt.system_gain_dn_per_e, pt.system_gain_sigma);
    text += line("    dark noise        %.3f e-\n", pt.dark_noise_e);
    text += line("    saturation        %.0f e- (mean %.1f DN above dark)\n", pt.saturation_capacity_e,
                 pt.saturation_mean_dn - pt.dark_mean_dn);
    text += line("    SNR max           %.2f (%.2f dB)\n", pt.snr_max, 20 * std::log10(pt.snr_max));
    text += line("    dynamic range     %.1f (%.2f dB)\n", pt.dynamic_range, 20 * std::log10(pt.dynamic_range));
    if (pt.expected_gain_dn_per_e > 0)
      text += line("    spec K x gain     %.5f DN/e- (measured/spec - 1 = %+.2f%%)\n", pt.expected_gain_dn_per_e,
                   100 * (pt.system_gain_dn_per_e / pt.expected_gain_dn_per_e - 1));
  } else if (!r.photon_transfer_error.empty()) {
    text += "  photon transfer: " + r.photon_transfer_error + "\n";
  }
  if (r.hdr) {
    text += line("  HDR merge: %zu exposures, %lld pixels clipped in every frame (flagged, lower bound given)\n",
                 r.linearity.size(), static_cast<long long>(r.hdr->clipped_everywhere));
    if (r.hdr_median_relative_error)
      text += line("    median radiance error vs truth %.3f%%\n", 100 * *r.hdr_median_relative_error);
  } else if (!r.hdr_error.empty()) {
    text += "  HDR merge: " + r.hdr_error + "\n";
  }
  if (!args.plots_dir.empty()) plot_exposure(args, r);
  emit(args, analysis::to_json(r), text);
}

void write_png(const std::filesystem::path& path, const cv::Mat& image) {
  try {
    if (!cv::imwrite(path.string(), image)) fail("cannot write " + path.string());
  } catch (const cv::Exception& e) {
    fail("cannot write " + path.string() + ": " + e.what());
  }
}

void plot_focus(const AnalyzeArgs& args, const analysis::FocusReport& r) {
  const auto dir = plots_dir(args);
  // Depth map: nearer = brighter (inverse distance, scaled to the valid range); invalid
  // pixels black.
  cv::Mat inv = cv::Mat::zeros(r.depth_m.size(), CV_32F);
  double lo = 1e300, hi = 0;
  for (int y = 0; y < r.depth_m.rows; ++y)
    for (int x = 0; x < r.depth_m.cols; ++x) {
      const float d = r.depth_m.at<float>(y, x);
      if (d <= 0) continue;
      inv.at<float>(y, x) = 1.0f / d;
      lo = std::min(lo, 1.0 / d);
      hi = std::max(hi, 1.0 / d);
    }
  cv::Mat gray, colour;
  const double span = hi > lo ? hi - lo : 1.0;
  inv.convertTo(gray, CV_8U, 254.0 / span, 1.0 - 254.0 * lo / span);
  gray.setTo(0, r.valid == 0);
  cv::applyColorMap(gray, colour, cv::COLORMAP_VIRIDIS);
  colour.setTo(cv::Scalar(0, 0, 0), r.valid == 0);
  write_png(dir / "depth_map.png", colour);
  write_png(dir / "all_in_focus.png", r.all_in_focus);
  analysis::PlotSpec spec{"focus measure per region", "focus position (steps)", "normalised measure", false, true, {}};
  int colour_index = 0;
  for (const auto& rr : r.regions) {
    if (rr.focus.status != analysis::kFocusOk || colour_index >= 6) continue;
    static const int colours[] = {0xc00000, 0x008000, 0x0000c0, 0x808000, 0x800080, 0x008080};
    analysis::PlotSeries s{line("(%d,%d) best %.2f", rr.focus.rect.x, rr.focus.rect.y, rr.best_position),
                           r.positions, rr.focus.curve, {}, true, colours[colour_index++]};
    spec.series.push_back(s);
  }
  if (!spec.series.empty()) check(analysis::write_plot(dir / "focus_curves.png", spec));
}

void run_focus(const AnalyzeArgs& args) {
  analysis::FocusStackOptions options;
  options.region_px = args.region_px;
  options.window_px = args.window_px;
  auto report = analysis::analyze_focus(args.dir, options);
  if (!report) fail(report.error().message);
  const analysis::FocusReport& r = *report;
  int ok = 0, flat = 0, end = 0;
  for (const auto& rr : r.regions) {
    ok += rr.focus.status == analysis::kFocusOk;
    flat += rr.focus.status == analysis::kFocusFlat;
    end += rr.focus.status == analysis::kFocusPeakAtEnd;
  }
  std::string text = line("focus stack: %zu positions (%g..%g), %zu regions of %d px: %d ok, %d flat, %d peak at an end\n",
                          r.positions.size(), r.positions.front(), r.positions.back(), r.regions.size(),
                          args.region_px, ok, flat, end);
  text += "  region (x,y)     status         best position  sigma [steps]  distance [m]\n";
  for (const auto& rr : r.regions) {
    const double step = r.positions.size() > 1 ? (r.positions.back() - r.positions.front()) / (r.positions.size() - 1) : 0;
    text += line("  (%4d,%4d)  %-14s %12.3f %12.3f", rr.focus.rect.x, rr.focus.rect.y, rr.focus.status.c_str(),
                 rr.best_position, rr.focus.best_index_sigma * step);
    text += rr.distance_m ? (std::isfinite(*rr.distance_m) ? line("  %10.4f\n", *rr.distance_m) : std::string("    infinity\n"))
                          : std::string("\n");
  }
  text += line("  depth map: %.1f%% of pixels valid\n", 100.0 * cv::countNonZero(r.valid) / double(r.valid.total()));
  if (!args.plots_dir.empty()) plot_focus(args, r);
  emit(args, analysis::to_json(r), text);
}

void add_common(CLI::App* sub, AnalyzeArgs* args) {
  sub->add_option("DIR", args->dir, "capture folder")->required()->check(CLI::ExistingDirectory);
  sub->add_flag("--json", args->json, "print the report as JSON");
  sub->add_option("--report", args->report_path, "also write the JSON report to this file");
  sub->add_option("--plots", args->plots_dir, "write PNG plots into this folder");
}

}  // namespace

void register_analyze_command(CLI::App& app) {
  auto args = std::make_shared<AnalyzeArgs>();
  CLI::App* analyze = app.add_subcommand("analyze", "measure optics from a capture folder: defocus, exposure, focus");
  analyze->require_subcommand(1);

  CLI::App* defocus = analyze->add_subcommand(
      "defocus", "blur-disk diameter per slanted edge; C = k/N over an aperture series, the "
                 "V-curve over a focus sweep");
  add_common(defocus, args.get());
  defocus->add_option("--baseline-sigma", args->baseline_sigma_px,
                      "in-focus Gaussian blur of the lens in px (default: from the capture)")
      ->check(CLI::Range(0.0, 50.0));
  defocus->add_option("--min-diameter", args->min_diameter_px,
                      "smallest blur (px) used in the fits")->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  defocus->add_option("--coc", args->acceptable_coc_px,
                      "acceptable CoC (px) for the depth of field")->capture_default_str()
      ->check(CLI::Range(0.01, 1000.0));
  defocus->add_option("--threads", args->threads, "frames measured in parallel")
      ->capture_default_str()->check(CLI::Range(1, 16));
  defocus->callback([args] { run_defocus(*args); });

  CLI::App* exposure = analyze->add_subcommand(
      "exposure", "linearity in T x gain, EMVA 1288 photon transfer from frame pairs, HDR merge");
  add_common(exposure, args.get());
  exposure->callback([args] { run_exposure(*args); });

  CLI::App* focus = analyze->add_subcommand(
      "focus", "focus stack: best focus per region and pixel, depth map, all-in-focus image");
  add_common(focus, args.get());
  focus->add_option("--region", args->region_px, "region size in px")->capture_default_str()
      ->check(CLI::Range(4, 4096));
  focus->add_option("--window", args->window_px, "per-pixel measure window in px (odd)")
      ->capture_default_str()->check(CLI::Range(1, 255));
  focus->callback([args] { run_focus(*args); });
}

}  // namespace camlab::cli
