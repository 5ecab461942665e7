#include "analysis/lightfield/refocus.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "analysis/lightfield/lattice_resampler.h"
#include "base/format.h"
#include "optics/aperture_cells.h"

namespace camlab::analysis::lightfield {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A view's cell in units of the aperture radius, and the second moment ((x^2 + y^2) / 2)
// of its effective lens point: where a point at the capture's focus lands in the view.
struct CellMoments {
  double x0, x1, y0, y1;
  double second_moment;
};

std::vector<CellMoments> cell_moments(const image::LightFieldDescription& d, double radius_m) {
  std::vector<CellMoments> out;
  for (const image::LightFieldView& v : d.views) {
    const double cx = v.centroid_m[0] / radius_m, cy = v.centroid_m[1] / radius_m;
    out.push_back({v.cell_m[0] / radius_m, v.cell_m[1] / radius_m, v.cell_m[2] / radius_m,
                   v.cell_m[3] / radius_m, 0.5 * (cx * cx + cy * cy)});
  }
  return out;
}

// Weights cut from a disk of radius `rho` (units of R) and the radius of the uniform
// disk with their second moment.
double weigh(const std::vector<CellMoments>& cells, double rho, std::vector<float>* weights) {
  double sum = 0, moment = 0;
  weights->assign(cells.size(), 0.f);
  for (size_t k = 0; k < cells.size(); ++k) {
    const CellMoments& c = cells[k];
    const double w = optics::disk_rect_moments(c.x0, c.x1, c.y0, c.y1, rho).area;
    (*weights)[k] = static_cast<float>(w);
    sum += w;
    moment += w * c.second_moment;
  }
  if (!(sum > 0)) return 0;
  for (float& w : *weights) w = static_cast<float>(w / sum);
  // A uniform disk of radius r has a mean (x^2 + y^2) / 2 of r^2 / 4.
  return 2 * std::sqrt(moment / sum);
}

}  // namespace

Result<SyntheticAperture> synthetic_aperture(const image::LightFieldDescription& d,
                                             double f_number) {
  const double captured = d.optics.f_number;
  SyntheticAperture a;
  const double radius_m = d.optics.focal_mm / captured / 2 * 1e-3;
  const std::vector<CellMoments> cells = cell_moments(d, radius_m);
  if (f_number == 0 || f_number == captured) {
    // The whole aperture: each view by its share of it.
    a.f_number = captured;
    const double rho = weigh(cells, 1.0, &a.weights);
    a.effective_f_number = captured / rho;
    a.mask_radius_m = radius_m;
  } else {
    // The smallest effective aperture the cells can give: the centre's alone.
    std::vector<float> unused;
    const double rho_min = weigh(cells, 1e-6, &unused);
    const double largest = captured / rho_min;
    if (!(f_number >= captured && f_number <= largest))
      return make_error(
          "out_of_range",
          "f_number = " + format_significant(f_number) + " is outside [" +
              format_significant(captured, 4) + ", " + format_significant(largest, 4) +
              "]: the captured aperture bounds it below, the central views' own "
              "spread (" +
              std::to_string(d.views_u) + " x " + std::to_string(d.views_v) + " views) above");
    // The mask radius whose weighted cells have the second moment of f/N: bisection (the
    // moment grows with the radius).
    const double target = captured / f_number;
    double lo = 1e-6, hi = 1.0;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (weigh(cells, mid, &unused) < target ? lo : hi) = mid;
    }
    const double rho = weigh(cells, 0.5 * (lo + hi), &a.weights);
    a.f_number = f_number;
    a.effective_f_number = captured / rho;
    a.mask_radius_m = 0.5 * (lo + hi) * radius_m;
  }
  a.views_used = static_cast<int>(
      std::count_if(a.weights.begin(), a.weights.end(), [](float w) { return w > 0; }));
  return a;
}

std::array<double, 2> sharp_refocus_range_m(const ViewGeometry& g) {
  // view_step_px = f_px cell |q_r - q| <= 1.
  const double dq = 1 / (g.f_px * g.cell_pitch_m);
  const double near_q = g.inverse_focus_per_m + dq, far_q = g.inverse_focus_per_m - dq;
  return {1 / near_q, far_q > 0 ? 1 / far_q : kInf};
}

Result<RefocusResult> refocus(const LightField& lf, double focus_m, double f_number) {
  const image::LightFieldDescription& d = lf.description;
  if (lf.views.size() < 2)
    return make_error("unsupported",
                      "a light field of one view (" + std::to_string(d.views_u) + " x " +
                          std::to_string(d.views_v) +
                          ") has no parallax: it cannot be refocused; render or capture at "
                          "least 2 x 2 views");
  const ViewGeometry g = view_geometry(d);
  RefocusResult r;
  r.focus_m = focus_m;
  CAMLAB_ASSIGN(r.lens_to_sensor_mm, refocus_lens_to_sensor_mm(g, focus_m));
  CAMLAB_ASSIGN(r.aperture, synthetic_aperture(d, f_number));
  r.magnification = r.lens_to_sensor_mm / g.lens_to_sensor_mm;
  const double q_r = std::isfinite(focus_m) ? 1 / focus_m : 0.0;
  const double dq = q_r - g.inverse_focus_per_m;
  r.view_step_px = g.f_px * g.cell_pitch_m * std::fabs(dq);
  r.sharp_range_m = sharp_refocus_range_m(g);
  if (r.view_step_px > 1)
    r.warnings.push_back(format_printf(
        "at focus_m = %.4g a point moves %.2f px between neighbouring views (more than 1 px): "
        "the refocused image keeps a blur of that width there; this light field refocuses "
        "sharply between %.4g and %.4g m",
        focus_m, r.view_step_px, r.sharp_range_m[0], r.sharp_range_m[1]));

  const cv::Size view_size = lf.views.front().size();
  const cv::Size out_size = LatticeResampler::square_grid_size(d.lattice, view_size);
  LatticeResampler resampler(d.lattice, view_size, out_size);
  r.image = cv::Mat(out_size, CV_32F, cv::Scalar(0));
  const double scale = 1 / r.magnification;
  const double cx = g.principal_point_px[0], cy = g.principal_point_px[1];
  // The magnification moves the image's corners by up to this much.
  const double spread =
      (1 - scale) * std::max({std::fabs(cx), std::fabs(out_size.width - 1 - cx), std::fabs(cy),
                              std::fabs(out_size.height - 1 - cy)});
  for (size_t k = 0; k < lf.views.size(); ++k) {
    const float w = r.aperture.weights[k];
    if (w <= 0) continue;
    const image::LightFieldView& v = d.views[k];
    const double shift_x = g.f_px * v.centroid_m[0] * dq, shift_y = g.f_px * v.centroid_m[1] * dq;
    r.border_px = std::max(r.border_px, std::hypot(shift_x, shift_y) + std::fabs(spread));
    resampler.accumulate(lf.views[k], scale, cx * (1 - scale) - shift_x, cy * (1 - scale) - shift_y,
                         w, r.image);
  }
  r.image *= scale * scale;  // a farther sensor: irradiance (z_s / z_r)^2
  return r;
}

}  // namespace camlab::analysis::lightfield
