// Light fields generated here, independently of the renderer and of the code under test:
// views of a straight edge or of a texture of sinusoids on a fronto-parallel plane, each
// view the same image shifted by its disparity f_px o (1/z - q) and integrated over the
// pixel in closed form, and the raw lenslet image a plenoptic sensor would record of any
// set of views, its cells' lit shares counted by brute force.
#pragma once

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

#include "analysis/lightfield/light_field.h"
#include "image/lightfield_folder.h"
#include "optics/aperture_cells.h"

namespace camlab::analysis::testing {

// The optics of the synthetic camera: 8 mm f/2, 4 um pixels, focused at 1 m.
struct SyntheticOptics {
  double focal_mm = 8.0, f_number = 2.0, pitch_um = 4.0, focus_m = 1.0;
  double lens_to_sensor_mm() const { return focal_mm * focus_m * 1e3 / (focus_m * 1e3 - focal_mm); }
  double f_px() const { return lens_to_sensor_mm() / (pitch_um * 1e-3); }
  double radius_m() const { return focal_mm / f_number / 2 * 1e-3; }
};

// A light field's description: U x U cells (the non-empty ones), a square lattice.
inline image::LightFieldDescription synthetic_description(int views, cv::Size size,
                                                          const SyntheticOptics& o = {}) {
  image::LightFieldDescription d;
  d.views_u = d.views_v = views;
  d.optics = {o.focal_mm, o.f_number, o.lens_to_sensor_mm(),
              o.focus_m,  o.pitch_um, {(size.width - 1) / 2.0, (size.height - 1) / 2.0}};
  const double r = o.radius_m();
  const auto cells = optics::aperture_cells(views, views);
  for (const optics::ApertureCell& c : *cells) {
    if (c.area_share <= 0) continue;
    d.views.push_back(image::view_of_cell(c.u_index, c.v_index, {c.x0, c.x1, c.y0, c.y1},
                                          {c.centroid_x, c.centroid_y}, c.area_share, r));
  }
  return d;
}

// The pixel integral of a unit step at 0 blurred by a Gaussian of sigma (px), over a pixel
// of width w centred at t: (G(t + w/2) - G(t - w/2)) / w, G(u) = u Phi(u/s) + s phi(u/s).
inline double blurred_step_pixel(double t, double sigma, double width = 1.0) {
  const auto g = [&](double u) {
    const double z = u / sigma;
    return u * 0.5 * std::erfc(-z / std::sqrt(2.0)) +
           sigma * std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI);
  };
  return (g(t + width / 2) - g(t - width / 2)) / width;
}

// A texture of sinusoids: a + sum b_k sin(kx x + ky y + phase_k), integrated over the
// unit pixel in closed form (each term times sinc(kx/2) sinc(ky/2)).
struct SineTexture {
  struct Wave {
    double kx, ky, phase, amplitude;
  };
  double mean = 1000;
  std::vector<Wave> waves;
  explicit SineTexture(unsigned seed, int count = 12, double amplitude = 600) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> angle(0, 2 * M_PI), frequency(0.25, 1.1);
    for (int i = 0; i < count; ++i) {
      const double a = angle(rng), k = frequency(rng);
      waves.push_back({k * std::cos(a), k * std::sin(a), angle(rng), amplitude / count});
    }
  }
  double pixel(double x, double y) const {
    const auto sinc = [](double u) { return std::fabs(u) < 1e-12 ? 1.0 : std::sin(u) / u; };
    double v = mean;
    for (const Wave& w : waves)
      v += w.amplitude * sinc(w.kx / 2) * sinc(w.ky / 2) * std::sin(w.kx * x + w.ky * y + w.phase);
    return v;
  }
};

// The views of a scene at depth z_m: where the central view has a point at x, the view
// through lens point o has it at x - f_px o (1/z - q) (the ray from o towards the plane of
// focus: the chief ray's m = X/z - o (1/z - q)), so view k's pixel (x, y) is
// `scene(x + d_x, y + d_y)` with d = f_px o_k (1/z - q).
template <class Scene>
analysis::lightfield::LightField synthetic_light_field(int views, cv::Size size, double z_m,
                                                       Scene&& scene,
                                                       const SyntheticOptics& o = {}) {
  analysis::lightfield::LightField lf;
  lf.description = synthetic_description(views, size, o);
  lf.bit_depth = 16;
  const double slope = o.f_px() * (1 / z_m - 1 / o.focus_m);  // px per metre of lens offset
  for (const image::LightFieldView& v : lf.description.views) {
    cv::Mat image(size, CV_32F);
    const double dx = slope * v.centroid_m[0], dy = slope * v.centroid_m[1];
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x)
        image.at<float>(y, x) = static_cast<float>(scene(x + dx, y + dy));
    lf.views.push_back(image);
  }
  return lf;
}

// The share of cell (i, j) of a U x U grid inside the unit disk, by a 600 x 600 count.
inline double counted_lit_share(int u, int i, int j) {
  const int n = 600;
  long inside = 0;
  for (int b = 0; b < n; ++b)
    for (int a = 0; a < n; ++a) {
      const double x = -1 + 2.0 * (i + (a + 0.5) / n) / u, y = -1 + 2.0 * (j + (b + 0.5) / n) / u;
      inside += x * x + y * y <= 1;
    }
  return static_cast<double>(inside) / (static_cast<double>(n) * n);
}

// The raw lenslet image and white image of `views` (U x U cells, view k = cell order,
// values in DN above black): microlens (k, l) puts its U x U block at
// (margin + k U + (staggered && l odd ? U/2 : 0), margin + l row_pitch), mirrored, each
// pixel lit by its cell's share (light of overlapping blocks adds); white at `white_dn`.
struct Lenslet {
  cv::Mat raw, white;  // CV_16U, black level `black`
};
inline Lenslet synthetic_lenslet(const std::vector<cv::Mat>& views,
                                 const image::LightFieldDescription& d, int margin, bool staggered,
                                 int row_pitch, int black, double white_dn) {
  const int u = d.views_u;
  const cv::Size size = views.front().size();
  const int width = 2 * margin + size.width * u + (staggered ? u / 2 : 0);
  const int height = 2 * margin + (size.height - 1) * row_pitch + u;
  cv::Mat raw(height, width, CV_64F, cv::Scalar(0)), white(height, width, CV_64F, cv::Scalar(0));
  for (size_t k = 0; k < views.size(); ++k) {
    const image::LightFieldView& v = d.views[k];
    const double lit = counted_lit_share(u, v.u_index, v.v_index);
    for (int l = 0; l < size.height; ++l)
      for (int m = 0; m < size.width; ++m) {
        const int x = margin + m * u + (staggered && l % 2 ? u / 2 : 0) + u - 1 - v.u_index;
        const int y = margin + l * row_pitch + u - 1 - v.v_index;
        raw.at<double>(y, x) += lit * views[k].at<float>(l, m);
        white.at<double>(y, x) += lit * white_dn;
      }
  }
  Lenslet out;
  raw.convertTo(out.raw, CV_16U, 1.0, black);  // rounds
  white.convertTo(out.white, CV_16U, 1.0, black);
  return out;
}

}  // namespace camlab::analysis::testing
