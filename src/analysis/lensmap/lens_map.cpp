#include "analysis/lensmap/lens_map.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>

#include <opencv2/core.hpp>

#include "analysis/lensmap/stop_exposure.h"
#include "base/format.h"
#include "image/capture_folder.h"

namespace camlab::analysis {

namespace {

using nlohmann::json;

constexpr int kMinFocusPositions = 5;
constexpr int kMinSurfaceEdges = 5;
constexpr const char* kChannelNames[3] = {"R", "G", "B"};

struct ThroughFocusPoint {
  double focus = 0;
  double mtf50 = 0;
  double centre_x_px = NAN, centre_y_px = NAN;  // the edge's centre in this frame
};

struct EdgeSeries {
  EdgeBestFocus edge;
  std::vector<ThroughFocusPoint> points;
  double fitted_from = 0, fitted_to = 0;  // the focus span the best focus was fitted over
};

// The through-focus points a best focus is fitted to: those around the peak whose MTF50 is
// at least this fraction of the peak's. A defocus disk much wider than the lens's own blur
// still gives 1 / MTF50^2 close to the parabola (MTF50 ~ 1 / diameter), so points far down
// the curve still place the vertex; each one added lowers the noise. Against half the peak,
// over 12 noise draws of the virtual lens-map capture (lens_map_bench), the astigmatism's
// rms error at f/1.4-2.8 went from 0.16-0.31 to 0.16-0.22 focus units and longitudinal
// colour's from 0.07-0.14 to 0.04-0.10, and without noise R and B stay within 0.074 of
// the truth (docs/analysis.md).
constexpr double kFittedFractionOfPeak = 0.25;
// Refits with the points weighted about the vertex (fit_best_focus), each about the last
// one's vertex. Each moves it less: over one lens-map bench draw's 567 edge fits the first
// moved it up to 0.33 focus units, the third 0.0075, the fourth 0.0016 (0.0002 of the
// sweep's step).
constexpr int kTaperIterations = 4;

// The vertex of the parabola 1 / MTF50^2 = a + b p + c p^2 fitted to the points around the
// peak whose MTF50 is at least kFittedFractionOfPeak of the peak's (at least the peak and
// one neighbour each side); lens_map.h says why 1 / MTF50^2.
void fit_best_focus(EdgeSeries* series) {
  EdgeBestFocus& e = series->edge;
  auto& pts = series->points;
  std::sort(pts.begin(), pts.end(), [](const ThroughFocusPoint& a, const ThroughFocusPoint& b) {
    return a.focus < b.focus;
  });
  e.through_focus.clear();
  for (const ThroughFocusPoint& p : pts) e.through_focus.emplace_back(p.focus, p.mtf50);
  if (pts.size() < 3) {
    e.status = pts.empty() ? kBestFocusNotMeasured : kBestFocusTooFewPoints;
    return;
  }
  const size_t peak = static_cast<size_t>(
      std::max_element(pts.begin(), pts.end(),
                       [](const auto& a, const auto& b) { return a.mtf50 < b.mtf50; }) -
      pts.begin());
  e.peak_mtf50_cy_px = pts[peak].mtf50;
  if (peak == 0 || peak + 1 == pts.size()) {
    e.status = kBestFocusAtSweepEnd;
    e.best_focus = pts[peak].focus;
    return;
  }
  size_t lo = peak - 1, hi = peak + 1;
  while (lo > 0 && pts[lo - 1].mtf50 >= kFittedFractionOfPeak * pts[peak].mtf50) --lo;
  while (hi + 1 < pts.size() && pts[hi + 1].mtf50 >= kFittedFractionOfPeak * pts[peak].mtf50) ++hi;
  // Centred and scaled for the normal equations' conditioning.
  const double p0 = pts[peak].focus;
  const double scale = std::max(pts[hi].focus - p0, p0 - pts[lo].focus);
  cv::Mat a(static_cast<int>(hi - lo + 1), 3, CV_64F), y(a.rows, 1, CV_64F);
  for (size_t i = lo; i <= hi; ++i) {
    const double t = (pts[i].focus - p0) / scale;
    const int r = static_cast<int>(i - lo);
    a.at<double>(r, 0) = 1;
    a.at<double>(r, 1) = t;
    a.at<double>(r, 2) = t * t;
    y.at<double>(r) = 1 / (pts[i].mtf50 * pts[i].mtf50);
  }
  cv::Mat coef;
  e.points = a.rows;
  series->fitted_from = pts[lo].focus;
  series->fitted_to = pts[hi].focus;
  if (!cv::solve(a, y, coef, cv::DECOMP_SVD) || !(coef.at<double>(2) > 0)) {
    e.status = kBestFocusNotAPeak;
    e.best_focus = p0;
    return;
  }
  double vertex = -coef.at<double>(1) / (2 * coef.at<double>(2));
  // Refitted with each point's row weighted by 1 - u^2, u its distance from the vertex over
  // the fitted curve's reach to a quarter of the peak (1 / MTF50^2 = 16 a0): the far points'
  // 1 / MTF50^2 is large and so is its noise (MTF50's relative error alike, squared and
  // inverted), and unweighted they steered the vertex most. Weighted alike on both sides of
  // the vertex, a curve alike on both sides keeps its peak.
  for (int iteration = 0; iteration < kTaperIterations; ++iteration) {
    const double c2 = coef.at<double>(2);
    const double a0 = coef.at<double>(0) - coef.at<double>(1) * coef.at<double>(1) / (4 * c2);
    if (!(a0 > 0)) break;
    const double reach = std::sqrt(15 * a0 / c2);  // t units
    cv::Mat aw(a.rows, 3, CV_64F), yw(a.rows, 1, CV_64F);
    int left = 0, right = 0;
    for (int r = 0; r < a.rows; ++r) {
      const double t = a.at<double>(r, 1), u = (t - vertex) / reach;
      const double w = std::fabs(u) >= 1 ? 0.0 : 1 - u * u;
      if (w > 0) (t < vertex ? left : right)++;
      for (int c = 0; c < 3; ++c) aw.at<double>(r, c) = w * a.at<double>(r, c);
      yw.at<double>(r) = w * y.at<double>(r);
    }
    cv::Mat next;
    if (left < 1 || right < 1 || left + right < 4 || !cv::solve(aw, yw, next, cv::DECOMP_SVD) ||
        !(next.at<double>(2) > 0))
      break;
    coef = next;
    vertex = -coef.at<double>(1) / (2 * coef.at<double>(2));
  }
  e.best_focus = p0 + vertex * scale;
  // A vertex outside the fitted points is an extrapolation, not a measured peak.
  if (!(e.best_focus >= pts[lo].focus && e.best_focus <= pts[hi].focus)) {
    e.status = kBestFocusNotAPeak;
    e.best_focus = p0;
  }
}

// Places a measured edge where it is at its best focus: a lens breathes (its image scale
// follows the lens-to-sensor distance), so an edge 275 px out moves 3.4 px along the
// radius over a 0.1 mm sweep of an 8 mm lens. The SFR refits each frame's line across the
// edge but keeps the segment's place along it, so an edge across the radius (meridional)
// moves and one along it does not: placed at their first frame's centres, the meridional
// edges sat 0.6% nearer the axis than at their best focus, and the map read about 1% of
// the field curvature as astigmatism (docs/analysis.md, "Where an edge is").
// The centres against focus: a straight line where the focus scale is linear in the
// extension, nearly one over the few frames about the peak where it is not (a voice-coil
// lens), so least squares over the frames the best focus was fitted to, at the best focus.
void place_at_best_focus(EdgeSeries* series) {
  EdgeBestFocus& e = series->edge;
  if (e.status != kBestFocusOk) return;
  double n = 0, sf = 0, sff = 0, sx = 0, sy = 0, sfx = 0, sfy = 0;
  for (const ThroughFocusPoint& p : series->points) {
    if (!std::isfinite(p.centre_x_px) || !std::isfinite(p.centre_y_px) ||
        p.focus < series->fitted_from || p.focus > series->fitted_to)
      continue;
    n += 1, sf += p.focus, sff += p.focus * p.focus;
    sx += p.centre_x_px, sy += p.centre_y_px;
    sfx += p.focus * p.centre_x_px, sfy += p.focus * p.centre_y_px;
  }
  if (n < 2) return;
  const double mean_f = sf / n, var_f = sff / n - mean_f * mean_f;
  if (!(var_f > 0)) return;
  const double slope_x = (sfx / n - mean_f * sx / n) / var_f;
  const double slope_y = (sfy / n - mean_f * sy / n) / var_f;
  e.centre_x_px = sx / n + slope_x * (e.best_focus - mean_f);
  e.centre_y_px = sy / n + slope_y * (e.best_focus - mean_f);
}

// Coefficients of a linear least-squares fit and their covariance, s^2 (A^T A)^-1 with s^2
// the residuals' variance (RSS / (n - k)): the scatter of the edges' best foci about the
// surface is what makes the coefficients uncertain.
struct LinearFit {
  std::vector<double> coef;
  cv::Mat covariance;  // k x k, CV_64F
  double variance(int i) const { return covariance.at<double>(i, i); }
};

// Least squares of `rows` (each: design row, value); the smallest singular value relative
// to the largest tells whether the columns are told apart by the data.
Result<LinearFit> least_squares(const std::vector<std::vector<double>>& rows,
                                const std::vector<double>& values, const char* what) {
  const int n = static_cast<int>(rows.size()), k = static_cast<int>(rows.front().size());
  cv::Mat a(n, k, CV_64F), y(n, 1, CV_64F);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < k; ++j) a.at<double>(i, j) = rows[i][j];
    y.at<double>(i) = values[i];
  }
  cv::SVD svd(a, cv::SVD::NO_UV);
  const double largest = svd.w.at<double>(0), smallest = svd.w.at<double>(k - 1);
  if (!(smallest > 1e-6 * largest))
    return make_error("singular",
                      std::string("the edges do not spread over the field enough to fit ") + what +
                          ": put edges at several distances from the centre and on " +
                          "both sides of it");
  cv::Mat coef;
  cv::solve(a, y, coef, cv::DECOMP_SVD);
  LinearFit fit;
  fit.coef.assign(coef.begin<double>(), coef.end<double>());
  const cv::Mat residual = a * coef - y;
  const double variance = n > k ? residual.dot(residual) / (n - k) : 0.0;
  fit.covariance = variance * (a.t() * a).inv(cv::DECOMP_SVD);
  return fit;
}

struct SurfaceFit {
  std::vector<double> all, by_class;  // coefficients; by_class empty when not fitted
  cv::Mat all_covariance, by_class_covariance;
  std::vector<double> residual;  // per edge of the surface, NaN where not used
};

// One least-squares pass over the edges whose status is ok.
Result<SurfaceFit> fit_once(const FocusSurface& surface, double width_px, double height_px) {
  const double cx = 0.5 * (width_px - 1), cy = 0.5 * (height_px - 1);
  const double half_diagonal = 0.5 * std::hypot(width_px, height_px);
  std::vector<std::vector<double>> all_rows, class_rows;
  std::vector<double> all_values, class_values;
  std::vector<size_t> all_edge, class_edge;
  int sagittal = 0, meridional = 0;
  for (size_t k = 0; k < surface.edges.size(); ++k) {
    const EdgeBestFocus& e = surface.edges[k];
    if (e.status != kBestFocusOk) continue;
    const double u = (e.centre_x_px - cx) / half_diagonal, v = (e.centre_y_px - cy) / half_diagonal;
    const double rho2 = u * u + v * v;
    all_rows.push_back({1, u, v, rho2});
    all_values.push_back(e.best_focus);
    all_edge.push_back(k);
    // The share of the meridional focus in this edge's blur, cos^2 of the angle between its
    // normal and the radius (lens_map.h); an edge on the axis, or of no known direction,
    // half of each.
    double meridional_share = 0.5;
    const double rho = std::sqrt(rho2);
    if (std::isfinite(e.angle_deg) && rho > 0.05) {
      const double a = e.angle_deg * std::numbers::pi / 180;
      const double cos_theta = (-std::sin(a) * u + std::cos(a) * v) / rho;
      meridional_share = cos_theta * cos_theta;
    }
    if (meridional_share > 0.75) ++meridional;
    if (meridional_share < 0.25) ++sagittal;
    class_rows.push_back({1, u, v, rho2 * (1 - meridional_share), rho2 * meridional_share});
    class_values.push_back(e.best_focus);
    class_edge.push_back(k);
  }
  if (static_cast<int>(all_rows.size()) < kMinSurfaceEdges)
    return make_error("too_few_samples",
                      format_printf("%zu edge(s) have a best focus at f/%g; the surface needs %d",
                                    all_rows.size(), surface.f_number, kMinSurfaceEdges));
  SurfaceFit fit;
  LinearFit all;
  CAMLAB_ASSIGN(all, least_squares(all_rows, all_values, "tilt and field curvature"));
  fit.all = std::move(all.coef);
  fit.all_covariance = all.covariance;
  fit.residual.assign(surface.edges.size(), std::nan(""));
  auto residuals = [&](const auto& rows, const auto& values, const auto& edge, const auto& c) {
    for (size_t i = 0; i < rows.size(); ++i) {
      double at = 0;
      for (size_t j = 0; j < c.size(); ++j) at += rows[i][j] * c[j];
      fit.residual[edge[i]] = values[i] - at;
    }
  };
  residuals(all_rows, all_values, all_edge, fit.all);
  // Sagittal and meridional curvatures apart only when each class has edges enough; then
  // the residuals are about the two surfaces (the astigmatism is no scatter).
  if (sagittal >= 3 && meridional >= 3)
    if (auto c = least_squares(class_rows, class_values, "sagittal and meridional curvature")) {
      fit.by_class = std::move(c->coef);
      fit.by_class_covariance = c->covariance;
      residuals(class_rows, class_values, class_edge, fit.by_class);
    }
  return fit;
}

// The surface through the edges' best foci, an edge whose best focus lies off it by more
// than 5 robust standard deviations (and 0.2% of the sweep's span) left out and the
// surface fitted again: an edge the finder placed on a corner or a neighbour's shadow
// must not bend the surface.
Result<FocusSurface> fit_surface(FocusSurface surface, double width_px, double height_px,
                                 double focus_span) {
  SurfaceFit fit;
  for (int round = 0; round < 3; ++round) {
    CAMLAB_ASSIGN(fit, fit_once(surface, width_px, height_px));
    std::vector<double> magnitude;
    for (double r : fit.residual)
      if (std::isfinite(r)) magnitude.push_back(std::fabs(r));
    std::nth_element(magnitude.begin(), magnitude.begin() + magnitude.size() / 2, magnitude.end());
    const double sigma = 1.4826 * magnitude[magnitude.size() / 2];
    const double bound = std::max(5 * sigma, 0.002 * focus_span);
    bool dropped = false;
    for (size_t k = 0; k < surface.edges.size(); ++k)
      if (std::isfinite(fit.residual[k]) && std::fabs(fit.residual[k]) > bound) {
        surface.edges[k].status = kBestFocusOffSurface;
        dropped = true;
      }
    if (!dropped) break;
  }
  double sum2 = 0;
  int used = 0;
  for (double r : fit.residual)
    if (std::isfinite(r)) {
      sum2 += r * r;
      ++used;
    }
  surface.edges_used = used;
  surface.rms_residual = std::sqrt(sum2 / std::max(used, 1));
  // With the classes apart, the two-surface fit gives the axis and the tilt too (one
  // surface through astigmatic edges bends them by the classes' placement), and the field
  // curvature is the medial surface's, halfway between the two.
  const bool by_class = !fit.by_class.empty();
  const std::vector<double>& c = by_class ? fit.by_class : fit.all;
  const cv::Mat& cov = by_class ? fit.by_class_covariance : fit.all_covariance;
  auto var = [&](int i, int j) { return cov.at<double>(i, j); };
  surface.centre_focus = c[0];
  surface.tilt_x = c[1];
  surface.tilt_y = c[2];
  surface.curvature = fit.all[3];
  surface.sigma.centre_focus = std::sqrt(var(0, 0));
  surface.sigma.tilt_x = std::sqrt(var(1, 1));
  surface.sigma.tilt_y = std::sqrt(var(2, 2));
  surface.sigma.curvature = std::sqrt(fit.all_covariance.at<double>(3, 3));
  if (by_class) {
    surface.curvature_sagittal = fit.by_class[3];
    surface.curvature_meridional = fit.by_class[4];
    surface.curvature = 0.5 * (fit.by_class[3] + fit.by_class[4]);
    // (c_s + c_m) / 2 and c_s - c_m from the two coefficients' covariance.
    surface.sigma.curvature = 0.5 * std::sqrt(var(3, 3) + var(4, 4) + 2 * var(3, 4));
    surface.sigma.astigmatism = std::sqrt(var(3, 3) + var(4, 4) - 2 * var(3, 4));
  }
  return surface;
}

json number_or_null(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

// One edge fit's lateral-colour samples: for R and B, (r.n, (o_c - o_G).n) with n the
// edge's normal, r its centre from the image centre and o the channels' offsets across the
// luminance's line (offset_px); both change sign with n, so its direction does not matter.
void add_lateral_samples(const json& edge, const json& channels, double centre_x, double centre_y,
                         std::array<std::vector<std::pair<double, double>>, 2>* samples) {
  const json centre = edge.value("centre_px", json());
  if (!centre.is_array() || centre.size() != 2 || !centre[0].is_number() ||
      !centre[1].is_number() || !edge.contains("angle_deg") || !edge["angle_deg"].is_number())
    return;
  auto offset = [&](const char* name) -> std::optional<std::array<double, 2>> {
    const json c = channels.value(name, json());
    if (!c.is_object() || c.value("status", std::string()) != kSfrOk) return std::nullopt;
    const json o = c.value("offset_px", json());
    if (!o.is_array() || o.size() != 2 || !o[0].is_number() || !o[1].is_number())
      return std::nullopt;
    return std::array<double, 2>{o[0].get<double>(), o[1].get<double>()};
  };
  const auto green = offset("G");
  if (!green) return;
  const double a = edge["angle_deg"].get<double>() * std::numbers::pi / 180;
  const double nx = -std::sin(a), ny = std::cos(a);
  const double r_n =
      (centre[0].get<double>() - centre_x) * nx + (centre[1].get<double>() - centre_y) * ny;
  for (int k = 0; k < 2; ++k)
    if (const auto c = offset(k == 0 ? "R" : "B"))
      (*samples)[static_cast<size_t>(k)].emplace_back(
          r_n, ((*c)[0] - (*green)[0]) * nx + ((*c)[1] - (*green)[1]) * ny);
}

// The channel's image scale against green's, s, from d = s r.n over the samples (least
// squares through the origin; samples more than 5 robust deviations off refitted once),
// given as the radial shift at the corner, s x half diagonal, with its standard error.
void fit_lateral_colour(const std::vector<std::pair<double, double>>& samples,
                        double half_diagonal_px, ChannelFocus* channel) {
  std::vector<std::pair<double, double>> used = samples;
  double s = 0, sigma = 0;
  size_t fitted = 0;  // samples in the last fit
  for (int round = 0; round < 2; ++round) {
    if (used.size() < 5) return;
    fitted = used.size();
    double sxx = 0, sxd = 0;
    for (const auto& [x, d] : used) sxx += x * x, sxd += x * d;
    if (!(sxx > 0)) return;
    s = sxd / sxx;
    std::vector<double> residual;
    double ss = 0;
    for (const auto& [x, d] : used) {
      residual.push_back(std::fabs(d - s * x));
      ss += (d - s * x) * (d - s * x);
    }
    sigma = std::sqrt(ss / static_cast<double>(used.size() - 1) / sxx);
    std::nth_element(residual.begin(), residual.begin() + residual.size() / 2, residual.end());
    const double bound = 5 * 1.4826 * residual[residual.size() / 2];
    std::vector<std::pair<double, double>> kept;
    for (const auto& [x, d] : used)
      if (std::fabs(d - s * x) <= bound) kept.emplace_back(x, d);
    if (kept.size() == used.size()) break;
    used = std::move(kept);
  }
  channel->lateral_px_at_corner = s * half_diagonal_px;
  channel->lateral_px_sigma = sigma * half_diagonal_px;
  channel->lateral_samples = static_cast<int>(fitted);
}

// Each colour channel's best focus: its edges' best foci (placed where the luminance found
// them), its own surface through them, and R and B against G edge by edge.
std::vector<ChannelFocus> channel_foci(const FocusSurface& luminance,
                                       std::array<std::map<std::string, EdgeSeries>, 3>* series,
                                       double width_px, double height_px, double focus_span) {
  std::array<std::map<std::string, EdgeBestFocus>, 3> best;
  std::vector<ChannelFocus> out;
  for (int c = 0; c < 3; ++c) {
    FocusSurface surface;
    for (const EdgeBestFocus& place : luminance.edges) {
      auto it = (*series)[static_cast<size_t>(c)].find(place.name);
      if (it == (*series)[static_cast<size_t>(c)].end()) continue;
      EdgeSeries& s = it->second;
      s.edge.centre_x_px = place.centre_x_px;
      s.edge.centre_y_px = place.centre_y_px;
      s.edge.field = place.field;
      s.edge.angle_deg = place.angle_deg;
      fit_best_focus(&s);
      // An edge the luminance's surface left out stays out of the channel's too.
      if (place.status == kBestFocusOffSurface && s.edge.status == kBestFocusOk)
        s.edge.status = kBestFocusOffSurface;
      surface.edges.push_back(s.edge);
      best[static_cast<size_t>(c)][place.name] = s.edge;
    }
    ChannelFocus f;
    f.channel = kChannelNames[c];
    if (auto fitted = fit_surface(std::move(surface), width_px, height_px, focus_span)) {
      f.edges_used = fitted->edges_used;
      f.centre_focus = fitted->centre_focus;
      f.centre_focus_sigma = fitted->sigma.centre_focus;
      // Edges the channel's own surface left out stay out of the differences.
      for (const EdgeBestFocus& e : fitted->edges)
        best[static_cast<size_t>(c)][e.name].status = e.status;
    }
    out.push_back(f);
  }
  for (int c : {0, 2}) {
    std::vector<double> d;
    for (const auto& [name, e] : best[static_cast<size_t>(c)]) {
      auto g = best[1].find(name);
      if (e.status == kBestFocusOk && g != best[1].end() && g->second.status == kBestFocusOk)
        d.push_back(e.best_focus - g->second.best_focus);
    }
    if (d.size() < 3) continue;
    double mean = 0;
    for (double v : d) mean += v;
    mean /= static_cast<double>(d.size());
    double ss = 0;
    for (double v : d) ss += (v - mean) * (v - mean);
    ChannelFocus& f = out[static_cast<size_t>(c)];
    f.minus_green = mean;
    f.minus_green_sigma =
        std::sqrt(ss / static_cast<double>(d.size() - 1) / static_cast<double>(d.size()));
    f.edges_paired = static_cast<int>(d.size());
  }
  return out;
}

}  // namespace

Result<std::vector<FocusSurface>> focus_surfaces(const json& sfr_report) {
  const json size = sfr_report.value("size_px", json());
  if (!size.is_array() || size.size() != 2 || !size[0].is_number() || !size[1].is_number())
    return make_error("invalid_argument", "the SFR report gives no image size (size_px)");
  // f-number -> edge name -> its series; f-number -> the focus positions. The same per
  // colour channel (index 0, 1, 2: R, G, B) when the frames are colour.
  std::map<double, std::map<std::string, EdgeSeries>> groups;
  std::map<double, std::array<std::map<std::string, EdgeSeries>, 3>> channel_groups;
  // f-number -> R and B (0, 1) -> (the edge's distance from the centre along its normal,
  // the channel's offset across the edge from green's), per measured edge fit.
  std::map<double, std::array<std::vector<std::pair<double, double>>, 2>> lateral;
  const double centre_x = 0.5 * (size[0].get<double>() - 1),
               centre_y = 0.5 * (size[1].get<double>() - 1);
  std::map<double, std::vector<double>> positions;
  for (const json& frame : sfr_report.value("frames", json::array())) {
    const json settings = frame.value("settings", json::object());
    if (!settings.contains("focus_position") || !settings["focus_position"].is_number()) continue;
    const double focus = settings["focus_position"].get<double>();
    const double n = settings.contains("f_number") && settings["f_number"].is_number()
                         ? std::round(settings["f_number"].get<double>() * 1000) / 1000
                         : 0.0;
    positions[n].push_back(focus);
    for (const json& e : frame.value("edges", json::array())) {
      const std::string name = e.value("name", std::string());
      EdgeSeries& series = groups[n][name];
      series.edge.name = name;
      const bool measured = e.value("status", std::string()) == kSfrOk &&
                            e.contains("mtf50_cy_px") && e["mtf50_cy_px"].is_number() &&
                            e["mtf50_cy_px"].get<double>() > 0;
      // Where the edge is: its first measured fit's centre, until then any fit's (a flagged
      // fit still places it); once its best focus is known, its centre there.
      const json centre = e.value("centre_px", json::array());
      if (centre.size() == 2 && centre[0].is_number() && centre[1].is_number() &&
          (series.edge.field.empty() || (measured && series.points.empty()))) {
        series.edge.centre_x_px = centre[0].get<double>();
        series.edge.centre_y_px = centre[1].get<double>();
        series.edge.field = e.value("field", std::string());
        if (e.contains("angle_deg") && e["angle_deg"].is_number())
          series.edge.angle_deg = e["angle_deg"].get<double>();
      }
      const json channels = e.value("channels", json());
      if (channels.is_object() && measured)
        add_lateral_samples(e, channels, centre_x, centre_y, &lateral[n]);
      if (channels.is_object())
        for (int c = 0; c < 3; ++c) {
          const json ch = channels.value(kChannelNames[c], json());
          EdgeSeries& cs = channel_groups[n][static_cast<size_t>(c)][name];
          cs.edge.name = name;
          if (!ch.is_object() || ch.value("status", std::string()) != kSfrOk ||
              !ch.contains("mtf50_cy_px") || !ch["mtf50_cy_px"].is_number() ||
              !(ch["mtf50_cy_px"].get<double>() > 0))
            continue;
          cs.points.push_back({focus, ch["mtf50_cy_px"].get<double>()});
        }
      if (!measured) continue;
      const double mtf50 = e["mtf50_cy_px"].get<double>();
      ThroughFocusPoint point{focus, mtf50};
      if (centre.size() == 2 && centre[0].is_number() && centre[1].is_number()) {
        point.centre_x_px = centre[0].get<double>();
        point.centre_y_px = centre[1].get<double>();
      }
      series.points.push_back(point);
    }
  }
  std::vector<FocusSurface> out;
  std::string why;
  for (auto& [n, edges] : groups) {
    auto& p = positions[n];
    std::sort(p.begin(), p.end());
    const int distinct = static_cast<int>(std::unique(p.begin(), p.end()) - p.begin());
    if (distinct < kMinFocusPositions) {
      why = format_printf("%d focus position(s) at f/%g; a focus sweep needs %d", distinct, n,
                          kMinFocusPositions);
      continue;
    }
    FocusSurface surface;
    surface.f_number = n;
    for (auto& [name, series] : edges) {
      fit_best_focus(&series);
      place_at_best_focus(&series);
      surface.edges.push_back(series.edge);
    }
    auto fitted = fit_surface(std::move(surface), size[0].get<double>(), size[1].get<double>(),
                              p[distinct - 1] - p[0]);
    if (!fitted) return fitted.error();
    if (auto it = channel_groups.find(n); it != channel_groups.end()) {
      fitted->channels = channel_foci(*fitted, &it->second, size[0].get<double>(),
                                      size[1].get<double>(), p[distinct - 1] - p[0]);
      const double half_diagonal = 0.5 * std::hypot(size[0].get<double>(), size[1].get<double>());
      for (int k = 0; k < 2; ++k)
        fit_lateral_colour(lateral[n][static_cast<size_t>(k)], half_diagonal,
                           &fitted->channels[static_cast<size_t>(2 * k)]);
    }
    out.push_back(std::move(*fitted));
  }
  if (out.empty())
    return make_error("too_few_samples",
                      why.empty() ? "no frame of the capture has a focus position" : why);
  return out;
}

namespace {

// The astigmatism of all f-numbers together: the inverse-variance mean of each surface's
// c_s - c_m. Third-order astigmatism (the sagittal and meridional focal surfaces' distance)
// depends on the field, not on the stop, while each f-number's estimate scatters with its
// depth of focus (at f/5.6 four times f/1.4's), so the stopped-down surfaces add little
// and lose nothing. chi^2 of the f-numbers about the mean tells whether they agree (a lens
// whose astigmatism does change with the stop, or a surface misfit, shows there).
json pooled_astigmatism(const std::vector<FocusSurface>& surfaces, std::string* text) {
  double weight_sum = 0, weighted = 0;
  std::vector<std::pair<double, double>> each;  // (value, sigma)
  json f_numbers = json::array();
  for (const FocusSurface& s : surfaces)
    if (s.curvature_sagittal && s.curvature_meridional && s.sigma.astigmatism &&
        *s.sigma.astigmatism > 0) {
      const double a = *s.curvature_sagittal - *s.curvature_meridional,
                   sigma = *s.sigma.astigmatism;
      each.emplace_back(a, sigma);
      weight_sum += 1 / (sigma * sigma), weighted += a / (sigma * sigma);
      f_numbers.push_back(s.f_number > 0 ? json(s.f_number) : json(nullptr));
    }
  if (each.size() < 2) return nullptr;
  const double mean = weighted / weight_sum, sigma = 1 / std::sqrt(weight_sum);
  double chi2 = 0;
  for (const auto& [a, e] : each) chi2 += (a - mean) * (a - mean) / (e * e);
  const double dof = static_cast<double>(each.size() - 1);
  // About 3 sigma of a chi^2 with that many degrees of freedom.
  const bool agree = chi2 <= dof + 3 * std::sqrt(2 * dof);
  *text = format_printf(
      "all f-numbers: astigmatism %.3f +- %.3f at the corner (focus units, 1 sigma of the edges' "
      "scatter; %zu f-numbers weighted by their errors, chi^2 %.1f for %.0f degrees of "
      "freedom%s)\n",
      mean, sigma, each.size(), chi2, dof,
      agree ? "" : ": they disagree, read each f-number's own");
  return {{"at_corner", mean}, {"standard_error", sigma},   {"f_numbers", std::move(f_numbers)},
          {"chi2", chi2},      {"degrees_of_freedom", dof}, {"f_numbers_agree", agree}};
}

}  // namespace

Result<LensMapReport> analyze_lens_map(const std::filesystem::path& dir,
                                       const LensMapOptions& options) {
  SfrImageReport sfr;
  CAMLAB_ASSIGN(sfr, analyze_sfr_folder(dir, options.sfr));
  std::vector<FocusSurface> surfaces;
  CAMLAB_ASSIGN(surfaces, focus_surfaces(sfr.report));
  // Physical units from the camera spec the capture records, unless given.
  double extension_mm = options.extension_mm_per_step;
  // The SFR report's pitch is null when neither the option nor the camera spec gave one.
  const json& report_pitch = sfr.report["pixel_pitch_um"];
  double pitch_um = options.pixel_pitch_um > 0 ? options.pixel_pitch_um
                    : report_pitch.is_number() ? report_pitch.get<double>()
                                               : 0.0;
  if (!(extension_mm > 0)) {
    if (auto folder = image::CaptureFolder::open(dir)) {
      const json camera =
          folder->manifest().value("source", json::object()).value("camera_spec", json::object());
      const json focus = camera.is_object()
                             ? camera.value("lens", json::object()).value("focus", json::object())
                             : json::object();
      if (focus.is_object() && focus.contains("extension_mm_per_step") &&
          focus["extension_mm_per_step"].is_number())
        extension_mm = focus["extension_mm_per_step"].get<double>();
    }
  }
  const double width = sfr.report["size_px"][0].get<double>();
  const double height = sfr.report["size_px"][1].get<double>();
  const double half_diagonal_mm = 0.5 * std::hypot(width, height) * pitch_um * 1e-3;
  const bool physical = extension_mm > 0 && pitch_um > 0;
  LensMapReport out;
  out.text =
      "lensmap: " + dir.string() + ", best focus from MTF50 through focus, " +
      std::to_string(surfaces.size()) + " f-number(s)" +
      (physical ? format_printf(" (%.4g mm a focus step, %.4g um pixels)", extension_mm, pitch_um)
                : std::string(" (focus steps only: no lens extension or pixel pitch)")) +
      "\n";
  json list = json::array();
  // The summary: what was measured, what was left out and why, over every f-stop.
  json summary = {{"kind", "lensmap"},
                  {"f_numbers", json::array()},
                  {"edges", 0},
                  {"edges_used", 0},
                  {"left_out", json::object()}};
  for (const FocusSurface& s : surfaces) {
    json edges = json::array();
    std::map<std::string, int> left_out;
    for (const EdgeBestFocus& e : s.edges) {
      json j = {{"name", e.name},
                {"centre_px", {e.centre_x_px, e.centre_y_px}},
                {"angle_deg", std::isfinite(e.angle_deg) ? json(e.angle_deg) : json(nullptr)},
                {"field", e.field},
                {"status", e.status},
                {"peak_mtf50_cy_px", e.peak_mtf50_cy_px}};
      json through = json::array();
      for (const auto& [focus, mtf50] : e.through_focus) through.push_back({focus, mtf50});
      j["through_focus_mtf50"] = std::move(through);  // [focus, MTF50 cycles/px] pairs
      if (e.status == kBestFocusOk) {
        j["best_focus"] = e.best_focus;
        j["points"] = e.points;
      } else {
        ++left_out[e.status];
      }
      edges.push_back(std::move(j));
    }
    summary["f_numbers"].push_back(s.f_number > 0 ? json(s.f_number) : json(nullptr));
    summary["edges"] = summary["edges"].get<int>() + static_cast<int>(s.edges.size());
    summary["edges_used"] = summary["edges_used"].get<int>() + s.edges_used;
    for (const auto& [status, n] : left_out)
      summary["left_out"][status] = summary["left_out"].value(status, 0) + n;
    json surface = {{"f_number", s.f_number > 0 ? json(s.f_number) : json(nullptr)},
                    {"edges_used", s.edges_used},
                    {"left_out", left_out},
                    {"centre_focus", s.centre_focus},
                    {"tilt_x_per_half_diagonal", s.tilt_x},
                    {"tilt_y_per_half_diagonal", s.tilt_y},
                    {"curvature_at_corner", s.curvature},
                    {"curvature_sagittal_at_corner", number_or_null(s.curvature_sagittal)},
                    {"curvature_meridional_at_corner", number_or_null(s.curvature_meridional)},
                    {"rms_residual", s.rms_residual},
                    {"standard_errors",
                     {{"centre_focus", s.sigma.centre_focus},
                      {"tilt_x_per_half_diagonal", s.sigma.tilt_x},
                      {"tilt_y_per_half_diagonal", s.sigma.tilt_y},
                      {"curvature_at_corner", s.sigma.curvature},
                      {"astigmatism_at_corner", number_or_null(s.sigma.astigmatism)}}},
                    {"edges", std::move(edges)}};
    std::string colour_text;  // after the surface's lines
    if (!s.channels.empty()) {
      json channels = json::array();
      std::string colour, lateral;
      for (const ChannelFocus& c : s.channels) {
        channels.push_back(
            {{"channel", c.channel},
             {"edges_used", c.edges_used},
             {"centre_focus", c.centre_focus},
             {"centre_focus_standard_error", c.centre_focus_sigma},
             {"focus_minus_green", number_or_null(c.minus_green)},
             {"focus_minus_green_standard_error", number_or_null(c.minus_green_sigma)},
             {"edges_paired", c.edges_paired},
             {"lateral_colour_px_at_corner", number_or_null(c.lateral_px_at_corner)},
             {"lateral_colour_px_standard_error", number_or_null(c.lateral_px_sigma)},
             {"lateral_samples", c.lateral_samples}});
        if (c.minus_green)
          colour += format_printf(" %s %+.3f +- %.3f (%d edges)", c.channel.c_str(), *c.minus_green,
                                  c.minus_green_sigma.value_or(0), c.edges_paired);
        if (c.lateral_px_at_corner)
          lateral += format_printf(" %s %+.3f +- %.3f px (%d edge fits)", c.channel.c_str(),
                                   *c.lateral_px_at_corner, c.lateral_px_sigma.value_or(0),
                                   c.lateral_samples);
      }
      surface["channels"] = std::move(channels);
      if (!colour.empty())
        colour_text = format_printf(
            "  longitudinal colour, best focus minus green's (focus units):%s\n", colour.c_str());
      if (!lateral.empty())
        colour_text += format_printf(
            "  lateral colour, image outward of green's at the corner:%s\n", lateral.c_str());
    }
    std::string astig = "-";
    if (s.curvature_sagittal && s.curvature_meridional) {
      const double a = *s.curvature_sagittal - *s.curvature_meridional;
      surface["astigmatism_at_corner"] = a;
      astig = format_printf("%.3f +- %.3f", a, s.sigma.astigmatism.value_or(0));
    }
    out.text += format_printf(
        "f/%g: %d edge(s); best focus on the axis %.3f +- %.3f, tilt %.3f +- %.3f right %.3f +- "
        "%.3f down, curvature %.3f +- %.3f, astigmatism %s at the corner (focus units, 1 sigma), "
        "rms %.3f\n",
        s.f_number, s.edges_used, s.centre_focus, s.sigma.centre_focus, s.tilt_x, s.sigma.tilt_x,
        s.tilt_y, s.sigma.tilt_y, s.curvature, s.sigma.curvature, astig.c_str(), s.rms_residual);
    if (physical) {
      // The lens moves extension_mm a unit; the best-focus surface is where the sensor would
      // have to be, so a focus difference is a sensor-side distance of the same size.
      const double deg = 180 / std::numbers::pi;
      // d atan(t k) / dt = k / (1 + (t k)^2), k = extension / half diagonal.
      const double k = extension_mm / half_diagonal_mm;
      auto tilt_deg_sigma = [&](double t, double sigma) {
        return k / (1 + t * k * t * k) * sigma * deg;
      };
      json units = {{"curvature_um", s.curvature * extension_mm * 1e3},
                    {"tilt_x_deg", std::atan(s.tilt_x * k) * deg},
                    {"tilt_y_deg", std::atan(s.tilt_y * k) * deg},
                    {"standard_errors",
                     {{"curvature_um", s.sigma.curvature * extension_mm * 1e3},
                      {"tilt_x_deg", tilt_deg_sigma(s.tilt_x, s.sigma.tilt_x)},
                      {"tilt_y_deg", tilt_deg_sigma(s.tilt_y, s.sigma.tilt_y)}}}};
      if (surface.contains("astigmatism_at_corner")) {
        units["astigmatism_um"] =
            surface["astigmatism_at_corner"].get<double>() * extension_mm * 1e3;
        units["standard_errors"]["astigmatism_um"] =
            s.sigma.astigmatism.value_or(0) * extension_mm * 1e3;
      }
      out.text += format_printf(
          "  at the sensor: curvature %.1f +- %.1f um, tilt %.4f +- %.4f deg x, %.4f +- %.4f "
          "deg y\n",
          units["curvature_um"].get<double>(),
          units["standard_errors"]["curvature_um"].get<double>(), units["tilt_x_deg"].get<double>(),
          units["standard_errors"]["tilt_x_deg"].get<double>(), units["tilt_y_deg"].get<double>(),
          units["standard_errors"]["tilt_y_deg"].get<double>());
      for (const ChannelFocus& c : s.channels)
        if (c.minus_green) {
          units["longitudinal_colour_um"][c.channel] = *c.minus_green * extension_mm * 1e3;
          units["standard_errors"]["longitudinal_colour_um"][c.channel] =
              c.minus_green_sigma.value_or(0) * extension_mm * 1e3;
        }
      surface["at_sensor"] = std::move(units);
    }
    out.text += colour_text;
    list.push_back(std::move(surface));
  }
  std::string pooled_text;
  json pooled = pooled_astigmatism(surfaces, &pooled_text);
  if (!pooled.is_null() && physical) {
    pooled["astigmatism_um"] = pooled["at_corner"].get<double>() * extension_mm * 1e3;
    pooled["standard_error_um"] = pooled["standard_error"].get<double>() * extension_mm * 1e3;
  }
  out.text += pooled_text;
  json relative_exposure = relative_exposure_by_f_number(sfr.report);
  json warnings = json::array();
  if (auto warning = unequal_exposure_warning(relative_exposure)) {
    out.text += "warning: " + *warning + "\n";
    warnings.push_back(*warning);
  }
  out.report = {
      {"capture", dir.string()},
      {"astigmatism_all_f_numbers", std::move(pooled)},
      {"method",
       "best focus per edge: vertex of 1/MTF50^2 against focus (points at or above a "
       "quarter of the peak); surface p0 + tx u + ty v + c rho^2 over the field (half diagonal "
       "= 1)"},
      {"extension_mm_per_step", extension_mm > 0 ? json(extension_mm) : json(nullptr)},
      {"pixel_pitch_um", pitch_um > 0 ? json(pitch_um) : json(nullptr)},
      {"size_px", {width, height}},
      {"surfaces", std::move(list)},
      // Each f-number's exposure H (time x gain / N^2) over the best-exposed one's.
      {"relative_exposure", std::move(relative_exposure)},
      {"warnings", std::move(warnings)},
      {"summary", std::move(summary)}};
  return out;
}

}  // namespace camlab::analysis
