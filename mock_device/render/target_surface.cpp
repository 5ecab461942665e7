#include "mock_device/render/target_surface.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <opencv2/imgproc.hpp>

namespace camlab::mock {

std::array<double, 9> rotation_from_vector(double rx, double ry, double rz) {
  const double theta = std::sqrt(rx * rx + ry * ry + rz * rz);
  if (theta < 1e-12) return {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double kx = rx / theta, ky = ry / theta, kz = rz / theta;
  const double c = std::cos(theta), s = std::sin(theta), C = 1 - c;
  return {c + kx * kx * C,      kx * ky * C - kz * s, kx * kz * C + ky * s,
          ky * kx * C + kz * s, c + ky * ky * C,      ky * kz * C - kx * s,
          kz * kx * C - ky * s, kz * ky * C + kx * s, c + kz * kz * C};
}

TargetSurface::TargetSurface(const TargetSpec& spec, const RtCamTarget& rt,
                             std::shared_ptr<const cv::Mat> texture,
                             std::shared_ptr<const CharucoPattern> charuco)
    : spec_(&spec), texture_(std::move(texture)), charuco_(std::move(charuco)) {
  R_ = rotation_from_vector(rt[0], rt[1], rt[2]);
  t_ = {rt[3], rt[4], rt[5]};
  n_ = {R_[2], R_[5], R_[8]};
  plane_offset_ = n_[0] * t_[0] + n_[1] * t_[1] + n_[2] * t_[2];
  x_min_ = spec.x_min_m();
  x_max_ = spec.x_max_m();
  y_min_ = spec.y_min_m();
  y_max_ = spec.y_max_m();
  const double angle_rad = spec.angle_deg * std::numbers::pi / 180.0;
  // The edge runs along (sin a, cos a): its normal, pointing to the light side, is
  // (cos a, -sin a).
  edge_cos_ = std::cos(angle_rad);
  edge_sin_ = std::sin(angle_rad);
  for (int c = 0; c <= kGrey; ++c) {
    dark_[c] = reflectance_in(spec.dark, c);
    light_[c] = reflectance_in(spec.light, c);
  }
  grey_ = spec.dark.is_grey() && spec.light.is_grey();
  if (texture_) {
    texels_per_m_u_ = (texture_->cols - 1) / (x_max_ - x_min_);
    texels_per_m_v_ = (texture_->rows - 1) / (y_max_ - y_min_);
    // As reflectance_at: a channel spans its own [dark, light] at the grey value's fraction
    // of the way (a grey target answers every channel with the grey value).
    const double grey_span = light_[kGrey] - dark_[kGrey];
    for (int c = 0; c < kGrey && !grey_; ++c) {
      texture_gain_[c] = grey_span == 0 ? 0 : (light_[c] - dark_[c]) / grey_span;
      texture_offset_[c] = grey_span == 0 ? light_[c] : dark_[c] - dark_[kGrey] * texture_gain_[c];
    }
  }
}

std::array<double, 3> TargetSurface::to_camera(double u, double v) const {
  return {R_[0] * u + R_[1] * v + t_[0], R_[3] * u + R_[4] * v + t_[1],
          R_[6] * u + R_[7] * v + t_[2]};
}

double TargetSurface::reflectance_at(double u, double v, int channel) const {
  const TargetSpec& s = *spec_;
  if (grey_) channel = kGrey;
  const double dark = dark_[channel], light = light_[channel];
  switch (s.type) {
    case TargetType::kChessboard: {
      // Squares span [-square, cols * square] x [-square, rows * square]; outside is the
      // light quiet zone. Square (i, j) with i + j even is dark, so the square whose
      // lower-right corner is the origin corner (i = j = -1) is dark.
      const double i = std::floor(u / s.square_m), j = std::floor(v / s.square_m);
      if (i < -1 || j < -1 || i > s.corners_cols - 1 || j > s.corners_rows - 1) return light;
      const bool is_dark = (static_cast<long>(i + j) & 1) == 0;
      // A marker disc is the other colour than its square.
      return is_dark != s.in_marker(u, v) ? dark : light;
    }
    case TargetType::kCharuco:
      return charuco_->light_at(u, v) ? light : dark;
    case TargetType::kSlantedEdge:
      return u * edge_cos_ - v * edge_sin_ < 0 ? dark : light;
    case TargetType::kBars: {
      const double period = s.bar_width_m + s.bar_gap_m;
      const double total = s.bar_count * period - s.bar_gap_m;
      const double x = u + total / 2;
      if (x < 0 || x >= total) return light;
      return std::fmod(x, period) < s.bar_width_m ? dark : light;
    }
    case TargetType::kTexture: {
      const cv::Mat& tex = *texture_;
      const double fx = (u - x_min_) / (x_max_ - x_min_) * (tex.cols - 1);
      const double fy = (v - y_min_) / (y_max_ - y_min_) * (tex.rows - 1);
      const int x0 = std::clamp(static_cast<int>(fx), 0, tex.cols - 2);
      const int y0 = std::clamp(static_cast<int>(fy), 0, tex.rows - 2);
      const double a = fx - x0, b = fy - y0;
      const float* r0 = tex.ptr<float>(y0);
      const float* r1 = tex.ptr<float>(y0 + 1);
      const double grey =
          (1 - b) * ((1 - a) * r0[x0] + a * r0[x0 + 1]) + b * ((1 - a) * r1[x0] + a * r1[x0 + 1]);
      if (channel == kGrey) return grey;
      // The texture spans [dark, light] in grey; a channel spans its own [dark, light]
      // at the same fraction of the way.
      const double grey_span = light_[kGrey] - dark_[kGrey];
      if (grey_span == 0) return light;
      return dark + (grey - dark_[kGrey]) / grey_span * (light - dark);
    }
    case TargetType::kUniform:
      return light;
  }
  return 0;
}

std::shared_ptr<const cv::Mat> make_texture(const TargetSpec& spec) {
  if (spec.type != TargetType::kTexture) return nullptr;
  // White noise on a grid of one cell per feature, smoothed to remove the grid, then
  // upsampled smoothly: band-limited, isotropic enough for focus measures, and cheap to
  // sample bilinearly at render time.
  const int cells_x = std::max(4, static_cast<int>(std::ceil(spec.width_m / spec.feature_m)) + 1);
  const int cells_y = std::max(4, static_cast<int>(std::ceil(spec.height_m / spec.feature_m)) + 1);
  cv::Mat noise(cells_y, cells_x, CV_32F);
  std::mt19937_64 rng(spec.texture_seed);
  std::normal_distribution<float> normal(0.f, 1.f);
  for (int y = 0; y < cells_y; ++y)
    for (int x = 0; x < cells_x; ++x) noise.at<float>(y, x) = normal(rng);
  cv::GaussianBlur(noise, noise, cv::Size(), 0.7, 0.7, cv::BORDER_REFLECT);
  const int up = 8;  // texels per feature: smooth at any magnification up to ~8 px/feature
  cv::Mat texture;
  cv::resize(noise, texture, cv::Size(cells_x * up, cells_y * up), 0, 0, cv::INTER_CUBIC);
  cv::Scalar mean, stddev;
  cv::meanStdDev(texture, mean, stddev);
  // Map +-2 sigma onto [dark, light] and clip: strong contrast, no saturation of the range.
  const double scale = (spec.light_reflectance - spec.dark_reflectance) / (4 * stddev[0] + 1e-12);
  const double mid = (spec.light_reflectance + spec.dark_reflectance) / 2;
  texture = (texture - mean[0]) * scale + mid;
  cv::min(texture, std::max(spec.light_reflectance, spec.dark_reflectance), texture);
  cv::max(texture, std::min(spec.light_reflectance, spec.dark_reflectance), texture);
  return std::make_shared<const cv::Mat>(std::move(texture));
}

}  // namespace camlab::mock
