// Plots of the analysis reports (analyze_folder.h), through plot.h.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <system_error>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/analyze_folder.h"
#include "analysis/focus/focus_report.h"
#include "analysis/plot.h"
#include "base/format.h"

namespace camlab::analysis {
namespace {

namespace fs = std::filesystem;
using Paths = std::vector<fs::path>;

Status make_dir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error("io_error", "cannot create " + dir.string() + ": " + ec.message());
  return {};
}

Status plot(const fs::path& path, const PlotSpec& spec, Paths* written) {
  if (Status s = write_plot(path, spec); !s) return s;
  written->push_back(path);
  return {};
}

Status png(const fs::path& path, const cv::Mat& image, Paths* written) {
  try {
    if (!cv::imwrite(path.string(), image))
      return make_error("io_error", "cannot write " + path.string());
  } catch (const cv::Exception& e) {
    return make_error("io_error", "cannot write " + path.string() + ": " + e.what());
  }
  written->push_back(path);
  return {};
}

// An image to look at: deeper than 8 bits, the 0.1% and 99.9% points of its values become
// 0 and 255, with a 1/2.2 power between (as the dashboard shows frames: a mid grey does
// not look black). 8-bit images are kept as they are.
cv::Mat display_mapped(const cv::Mat& image) {
  if (image.empty() || image.depth() == CV_8U) return image;
  cv::Mat values;
  image.reshape(1).convertTo(values, CV_32F);
  std::vector<float> sorted(values.begin<float>(), values.end<float>());
  const auto at = [&](double q) {
    const size_t k = std::min(sorted.size() - 1, static_cast<size_t>(q * (sorted.size() - 1)));
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(k), sorted.end());
    return sorted[k];
  };
  const float lo = at(0.001), hi = at(0.999);
  const float span = hi > lo ? hi - lo : 1.0f;
  cv::Mat out(values.size(), CV_8U);
  for (int y = 0; y < values.rows; ++y)
    for (int x = 0; x < values.cols; ++x) {
      const float v = std::clamp((values.at<float>(y, x) - lo) / span, 0.0f, 1.0f);
      out.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(255 * std::pow(v, 1 / 2.2f)));
    }
  return out.reshape(image.channels());
}

PlotSeries series(std::string label, bool line, int colour) {
  PlotSeries s;
  s.label = std::move(label);
  s.line = line;
  s.color_bgr = colour;
  return s;
}

}  // namespace

Result<Paths> write_defocus_plots(const fs::path& dir, const DefocusReport& r) {
  if (Status s = make_dir(dir); !s) return s.error();
  Paths written;
  for (const DefocusReport& channel : r.channels) {  // colour: one set per channel
    auto one = write_defocus_plots(dir, channel);
    if (!one) return one.error();
    written.insert(written.end(), one->begin(), one->end());
  }
  const std::string prefix = r.channel.empty() ? "" : r.channel + "_";
  const bool aperture = r.sweep == "f_number";
  // One chart for every target (one colour each: its measurements with 1-sigma bars and
  // its fit), so targets compare at a glance and none is left out silently: a target
  // without a fit shows its measurements and says so in the legend.
  constexpr int kPalette[] = {0xb05000, 0x0000c0, 0x008000, 0x8000a0, 0x0080e0,
                              0x606060, 0xa0a000, 0x4040ff, 0x00a0a0, 0x804000};
  PlotSpec spec;
  spec.title = prefix + (aperture ? "CoC against f-number, C = k / N fitted per edge"
                                  : "V-curves: blur against focus, |p - p0| slope fitted per edge");
  spec.x_label = aperture ? "f-number N" : "focus position (steps)";
  spec.y_label = "blur diameter (px, 1 sigma bars)";
  spec.width_px = 760;
  spec.height_px = 520;
  int shown = 0;
  for (const TargetDefocus& t : r.targets) {
    const int colour = kPalette[shown % std::size(kPalette)];
    PlotSeries measured = series("", false, colour);
    for (const auto& fe : t.frames) {
      if (!fe.edge.measured()) continue;
      measured.x.push_back(aperture ? fe.f_number : fe.focus_position);
      measured.y.push_back(fe.edge.diameter_px);
      measured.y_error.push_back(fe.edge.diameter_sigma_px);
    }
    if (measured.x.empty()) continue;
    ++shown;
    const auto [lo_it, hi_it] = std::minmax_element(measured.x.begin(), measured.x.end());
    PlotSeries fit = series("", true, colour);
    if (aperture && t.aperture) {
      fit.label = format_printf("%s: k = %.3f px", t.name.c_str(), t.aperture->k_px);
      for (double n = *lo_it; n <= *hi_it * 1.001; n *= 1.02) {
        fit.x.push_back(n);
        fit.y.push_back(t.aperture->k_px / n);
      }
    } else if (!aperture && t.v_curve) {
      fit.label = format_printf("%s: best %.2f", t.name.c_str(), t.v_curve->best_position);
      for (double p : {*lo_it, t.v_curve->best_position, *hi_it}) {
        fit.x.push_back(p);
        fit.y.push_back(t.v_curve->slope_px_per_step * std::fabs(p - t.v_curve->best_position));
      }
    } else {
      measured.label = t.name + ": no fit";
    }
    spec.series.push_back(std::move(measured));
    if (!fit.x.empty()) spec.series.push_back(std::move(fit));
  }
  if (shown > 0)
    if (Status s =
            plot(dir / (prefix + (aperture ? "coc_vs_n.png" : "v_curves.png")), spec, &written);
        !s)
      return s.error();
  return written;
}

Result<Paths> write_exposure_plots(const fs::path& dir, const ExposureReport& r) {
  if (Status s = make_dir(dir); !s) return s.error();
  Paths written;
  for (const ExposureReport& channel : r.channels) {  // colour: one set per channel
    auto one = write_exposure_plots(dir, channel);
    if (!one) return one.error();
    written.insert(written.end(), one->begin(), one->end());
  }
  const std::string prefix = r.channel.empty() ? "" : r.channel + "_";
  if (r.photon_transfer) {
    const auto& pt = *r.photon_transfer;
    PlotSpec spec;
    spec.title = prefix + "photon transfer";
    spec.x_label = "mean signal above dark (DN)";
    spec.y_label = "temporal variance (DN^2)";
    PlotSeries pts = series("frame pairs", false, 0xc00000),
               used = series("used in the fit", false, 0x008000);
    for (const auto& p : pt.points) {
      (p.used ? used : pts).x.push_back(p.mean_dn - pt.dark_mean_dn);
      (p.used ? used : pts).y.push_back(p.variance_dn2);
    }
    PlotSeries fit =
        series(format_printf("K = %.4f DN/e-", pt.system_gain_dn_per_e), true, 0x0000c0);
    for (double m : {0.0, pt.saturation_mean_dn - pt.dark_mean_dn}) {
      fit.x.push_back(m);
      fit.y.push_back(pt.dark_variance_dn2 + pt.system_gain_dn_per_e * m);
    }
    spec.series = {pts, used, fit};
    if (Status s = plot(dir / (prefix + "photon_transfer.png"), spec, &written); !s)
      return s.error();
  }
  if (!r.linearity.empty()) {
    PlotSpec spec;
    spec.title = "linearity";
    spec.x_label = "exposure x gain (us)";
    spec.y_label = "mean signal above dark (DN)";
    PlotSeries pts = series("frames", false, 0xc00000);
    PlotSeries fit =
        series(format_printf("max error %.2f%%", r.max_linearity_error_pct), true, 0x0000c0);
    for (const auto& l : r.linearity) {
      pts.x.push_back(l.exposure_gain_us);
      pts.y.push_back(l.mean_dn);
      fit.x.push_back(l.exposure_gain_us);
      fit.y.push_back(r.linearity_slope_dn_per_us * l.exposure_gain_us);
    }
    spec.series = {pts, fit};
    if (Status s = plot(dir / (prefix + "linearity.png"), spec, &written); !s) return s.error();
  }
  return written;
}

Result<Paths> write_focus_plots(const fs::path& dir, const FocusReport& r) {
  if (Status s = make_dir(dir); !s) return s.error();
  Paths written;
  // The depth map with its colour bar in metres: blocks of pixels (at most 160 across,
  // the mean of their valid depths), blank where no region had the texture to focus on.
  {
    const int width = r.depth_m.cols, height = r.depth_m.rows;
    const int block = std::max(1, (width + 159) / 160);
    PlotHeatmap depth;
    depth.cols = (width + block - 1) / block;
    depth.rows = (height + block - 1) / block;
    depth.x0 = 0, depth.x1 = depth.cols * block, depth.y0 = 0, depth.y1 = depth.rows * block;
    depth.label = "distance (m)";
    for (int j = 0; j < depth.rows; ++j)
      for (int i = 0; i < depth.cols; ++i) {
        double sum = 0;
        int n = 0;
        for (int y = j * block; y < std::min(height, (j + 1) * block); ++y)
          for (int x = i * block; x < std::min(width, (i + 1) * block); ++x) {
            const float d = r.depth_m.at<float>(y, x);
            if (d > 0 && std::isfinite(d) && (r.valid.empty() || r.valid.at<uint8_t>(y, x))) {
              sum += d;
              ++n;
            }
          }
        depth.values.push_back(n ? sum / n : std::nan(""));
      }
    PlotSpec map;
    map.title = "depth from focus (blank: too little texture to focus on)";
    map.x_label = "x (px)";
    map.y_label = "y (px)";
    map.y_down = true;
    map.equal_aspect = true;
    map.width_px = 820;
    map.height_px = 600;
    map.heatmap = std::move(depth);
    const bool any = std::any_of(map.heatmap->values.begin(), map.heatmap->values.end(),
                                 [](double v) { return std::isfinite(v); });
    if (any)
      if (Status s = plot(dir / "depth_map.png", map, &written); !s) return s.error();
  }
  // The all-in-focus image to look at, and its raw DN to measure on: a 10-bit sensor's DN in
  // a 16-bit PNG show black in any viewer (issue 35's black rectangle).
  if (Status s = png(dir / "all_in_focus.png", display_mapped(r.all_in_focus), &written); !s)
    return s.error();
  if (r.all_in_focus.depth() != CV_8U)
    if (Status s = png(dir / "all_in_focus_raw.png", r.all_in_focus, &written); !s)
      return s.error();
  PlotSpec spec;
  spec.title = "focus measure per region";
  spec.x_label = "focus position (steps)";
  spec.y_label = "normalised measure";
  spec.log_y = true;
  static const int colours[] = {0xc00000, 0x008000, 0x0000c0, 0x808000, 0x800080, 0x008080};
  int colour_index = 0;
  for (const auto& rr : r.regions) {
    if (rr.focus.status != kFocusOk || colour_index >= 6) continue;
    PlotSeries s = series(format_printf("(%d,%d) best %.2f", static_cast<int>(rr.focus.rect.x),
                                        static_cast<int>(rr.focus.rect.y), rr.best_position),
                          true, colours[colour_index++]);
    s.x = r.positions;
    s.y = rr.focus.curve;
    spec.series.push_back(s);
  }
  const auto focused = std::count_if(r.regions.begin(), r.regions.end(),
                                     [](const auto& rr) { return rr.focus.status == kFocusOk; });
  // Never a silent subset: the title says how many of the regions the chart shows.
  spec.title += format_printf(" (%zu of the %ld regions with a focus peak)", spec.series.size(),
                              static_cast<long>(focused));
  if (!spec.series.empty())
    if (Status s = plot(dir / "focus_curves.png", spec, &written); !s) return s.error();
  return written;
}

Result<Paths> write_lens_map_plots(const fs::path& dir, const nlohmann::json& report) {
  if (Status s = make_dir(dir); !s) return s.error();
  Paths written;
  const nlohmann::json& size = report["size_px"];
  if (!size.is_array() || size.size() != 2) return written;
  const double width = size[0].get<double>(), height = size[1].get<double>();
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
  const double half_diagonal = 0.5 * std::hypot(width, height);
  for (const nlohmann::json& s : report["surfaces"]) {
    const double n = s["f_number"].is_number() ? s["f_number"].get<double>() : 0.0;
    std::string tag = n > 0 ? format_printf("f%.3g", n) : std::string("f-");
    std::replace(tag.begin(), tag.end(), '.', '_');
    const std::string stop = n > 0 ? format_printf("f/%.3g", n) : std::string("unknown f-number");

    // The surface p0 + tx u + ty v + c rho^2 on a grid over the imager (the medial surface
    // when sagittal and meridional are apart), the edges where they are.
    PlotSpec map;
    map.title = "best focus over the field, " + stop;
    map.x_label = "x (px)";
    map.y_label = "y (px)";
    map.y_down = true;
    map.equal_aspect = true;
    map.x_range = std::pair<double, double>{0, width};
    map.y_range = std::pair<double, double>{0, height};
    PlotHeatmap heat;
    heat.cols = 64;
    heat.rows = std::max(2, static_cast<int>(std::lround(64 * height / width)));
    heat.x0 = 0, heat.x1 = width, heat.y0 = 0, heat.y1 = height;
    heat.label = "focus (steps)";
    const double p0 = s["centre_focus"], tx = s["tilt_x_per_half_diagonal"],
                 ty = s["tilt_y_per_half_diagonal"], c = s["curvature_at_corner"];
    for (int j = 0; j < heat.rows; ++j)
      for (int i = 0; i < heat.cols; ++i) {
        const double x = (i + 0.5) * width / heat.cols, y = (j + 0.5) * height / heat.rows;
        const double u = (x - 0.5 - cx) / half_diagonal, v = (y - 0.5 - cy) / half_diagonal;
        heat.values.push_back(p0 + tx * u + ty * v + c * (u * u + v * v));
      }
    map.heatmap = heat;
    PlotSeries used = series("edges used", false, 0xffffff),
               left = series("left out", false, 0x0000ff);
    used.marker_px = left.marker_px = 4;
    for (const nlohmann::json& e : s["edges"]) {
      PlotSeries& into = e["status"] == "ok" ? used : left;
      into.x.push_back(e["centre_px"][0].get<double>() + 0.5);
      into.y.push_back(e["centre_px"][1].get<double>() + 0.5);
    }
    for (PlotSeries* p : {&used, &left})
      if (!p->x.empty()) map.series.push_back(*p);
    if (Status st = plot(dir / ("lensmap_surface_" + tag + ".png"), map, &written); !st)
      return st.error();

    // MTF50 across the field, as lens makers chart it against image height: each edge's
    // MTF50 at the axis' best focus (interpolated between the sweep's two nearest
    // positions) over its distance from the centre, sagittal and meridional apart. Where
    // the two classes part with height, the lens is astigmatic; where both fall, the field
    // curves away from the axis' focus.
    PlotSpec field;
    field.title =
        format_printf("MTF50 across the field at the axis' best focus (%.1f), ", p0) + stop;
    field.x_label = "image height (half diagonals from the centre)";
    field.y_label = "MTF50 (cycles/px)";
    field.x_range = std::pair<double, double>{0, 1};
    PlotSeries by_class[3] = {series("sagittal edges", false, 0xc00000),
                              series("meridional edges", false, 0x0000c0),
                              series("other edges", false, 0x808080)};
    for (const nlohmann::json& e : s["edges"]) {
      if (e["status"] != "ok") continue;
      const auto& points = e.value("through_focus_mtf50", nlohmann::json::array());
      std::optional<double> at_p0;
      for (size_t k = 1; k < points.size() && !at_p0; ++k) {
        const double a = points[k - 1][0].get<double>(), b = points[k][0].get<double>();
        if ((a - p0) * (b - p0) > 0 || a == b) continue;
        const double t = (p0 - a) / (b - a);
        at_p0 = (1 - t) * points[k - 1][1].get<double>() + t * points[k][1].get<double>();
      }
      if (!at_p0) continue;  // the sweep does not reach the axis' focus for this edge
      const std::string kind = e.value("field", std::string());
      PlotSeries& into = by_class[kind == "sagittal" ? 0 : kind == "meridional" ? 1 : 2];
      const double u = (e["centre_px"][0].get<double>() - cx) / half_diagonal,
                   v = (e["centre_px"][1].get<double>() - cy) / half_diagonal;
      into.x.push_back(std::hypot(u, v));
      into.y.push_back(*at_p0);
    }
    for (PlotSeries& p : by_class)
      if (!p.x.empty()) field.series.push_back(std::move(p));
    if (!field.series.empty())
      if (Status st = plot(dir / ("lensmap_field_mtf50_" + tag + ".png"), field, &written); !st)
        return st.error();

    // MTF50 through focus: one line an edge, sagittal blue, meridional red, the rest grey;
    // a legend entry per class.
    PlotSpec curves;
    curves.title = "MTF50 through focus, " + stop;
    curves.x_label = "focus position (steps)";
    curves.y_label = "MTF50 (cycles/px)";
    bool labelled[3] = {false, false, false};
    for (const nlohmann::json& e : s["edges"]) {
      const std::string field = e.value("field", std::string());
      const int k = field == "sagittal" ? 0 : field == "meridional" ? 1 : 2;
      static const int colours[3] = {0xc00000, 0x0000c0, 0x808080};
      static const char* const names[3] = {"sagittal edges", "meridional edges", "other edges"};
      PlotSeries line = series(labelled[k] ? "" : names[k], true, colours[k]);
      labelled[k] = true;
      for (const nlohmann::json& point : e.value("through_focus_mtf50", nlohmann::json::array())) {
        line.x.push_back(point[0].get<double>());
        line.y.push_back(point[1].get<double>());
      }
      if (line.x.size() >= 2) curves.series.push_back(std::move(line));
    }
    if (!curves.series.empty())
      if (Status st = plot(dir / ("lensmap_through_focus_" + tag + ".png"), curves, &written); !st)
        return st.error();
  }
  return written;
}

}  // namespace camlab::analysis
