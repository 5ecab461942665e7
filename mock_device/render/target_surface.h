// A scene target placed in the camera frame, ready for ray intersection: its plane, its
// extent and its reflectance as a function of target coordinates.
//
// Thread-safe for concurrent reads after construction (the texture is immutable).
#pragma once

#include <algorithm>
#include <array>
#include <memory>

#include <opencv2/core.hpp>

#include "mock_device/render/charuco_pattern.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::mock {

// What a pixel sees: colour channels 0, 1, 2 (R, G, B) of a Bayer sensor, or kGrey, the
// reflectance a monochrome sensor sees (Reflectance::grey).
inline constexpr int kRed = 0;
inline constexpr int kGreen = 1;
inline constexpr int kBlue = 2;
inline constexpr int kGrey = 3;

// The reflectance of `r` in `channel` (kRed .. kGrey).
inline double reflectance_in(const Reflectance& r, int channel) {
  return channel == kGrey ? r.grey : r.rgb[static_cast<size_t>(channel)];
}

// Rotation matrix (row-major 3x3) of an mrcal rotation vector (Rodrigues).
std::array<double, 9> rotation_from_vector(double rx, double ry, double rz);

// Reflectance of one region of a target in each channel (kRed .. kGrey).
struct RegionValues {
  double by_channel[4] = {0, 0, 0, 0};
  bool operator==(const RegionValues&) const = default;
};

// What a target holds over a box of its own coordinates (TargetSurface::structure_in).
struct LocalStructure {
  // kSmooth: a pattern without steps that changes over `scale_m` (a texture's features).
  enum Kind { kConstant, kOneLine, kSmooth, kComplex };
  Kind kind = kComplex;
  RegionValues negative;  // kConstant: the value; kOneLine: e_u u + e_v v < e0
  RegionValues positive;  // kOneLine: e_u u + e_v v > e0
  double e_u = 0, e_v = 0, e0 = 0;
  double scale_m = 0;  // kSmooth
};

class TargetSurface {
 public:
  // `texture`: a texture target's (make_texture); `charuco`: a ChArUco target's pattern
  // (CharucoPattern::create). Null for the other types.
  TargetSurface(const TargetSpec& spec, const RtCamTarget& rt_cam_target,
                std::shared_ptr<const cv::Mat> texture,
                std::shared_ptr<const CharucoPattern> charuco = nullptr);

  // Ray origin o and direction d in the camera frame (metres). Returns the ray parameter
  // lambda of the hit (point o + lambda d), or a negative number when the ray misses the
  // target or meets it behind the origin. On a hit, *reflectance is the surface's in
  // `channel` (kRed .. kGrey).
  double intersect(const double o[3], const double d[3], int channel, double* reflectance) const {
    const double denom = n_[0] * d[0] + n_[1] * d[1] + n_[2] * d[2];
    if (denom > -1e-12 && denom < 1e-12) return -1;  // ray parallel to the plane
    const double lambda = (plane_offset_ - (n_[0] * o[0] + n_[1] * o[1] + n_[2] * o[2])) / denom;
    if (lambda <= 0) return -1;
    const double p[3] = {o[0] + lambda * d[0] - t_[0], o[1] + lambda * d[1] - t_[1],
                         o[2] + lambda * d[2] - t_[2]};
    // Target coordinates: R^T (p - t); the rows of R^T are R's columns.
    const double u = R_[0] * p[0] + R_[3] * p[1] + R_[6] * p[2];
    const double v = R_[1] * p[0] + R_[4] * p[1] + R_[7] * p[2];
    if (u < x_min_ || u > x_max_ || v < y_min_ || v > y_max_) return -1;
    *reflectance = reflectance_at(u, v, channel);
    return lambda;
  }

  // Reflectance in `channel` at target coordinates (u, v) in metres, inside the extent.
  double reflectance_at(double u, double v, int channel) const;

  // For a texture target: reflectance_at without its dispatch, for the renderer's inner
  // loop (the same bilinear texel lookup, the channel's [dark, light] as a gain and offset).
  double texture_at(double u, double v, int channel) const {
    const cv::Mat& tex = *texture_;
    const double fx = (u - x_min_) * texels_per_m_u_, fy = (v - y_min_) * texels_per_m_v_;
    const int x0 = std::clamp(static_cast<int>(fx), 0, tex.cols - 2);
    const int y0 = std::clamp(static_cast<int>(fy), 0, tex.rows - 2);
    const double a = fx - x0, b = fy - y0;
    const float* r0 = tex.ptr<float>(y0) + x0;
    const float* r1 = tex.ptr<float>(y0 + 1) + x0;
    const double grey = (1 - b) * ((1 - a) * r0[0] + a * r0[1]) + b * ((1 - a) * r1[0] + a * r1[1]);
    return texture_offset_[channel] + texture_gain_[channel] * grey;
  }

  // A target point (metres, target frame) in the camera frame.
  std::array<double, 3> to_camera(double u, double v) const;

  // What the target's pattern is over the box [u0, u1] x [v0, v1] of target coordinates
  // (inside its extent): one value, two values split by one straight line, or more
  // (textures always). For the renderer's analytic paths (radiance_integrator.h).
  LocalStructure structure_in(double u0, double u1, double v0, double v1) const;

  // The plane n . X = c and the target's axes and origin, in the camera frame (metres);
  // its extent in target coordinates.
  const std::array<double, 3>& normal() const { return n_; }
  double plane_offset() const { return plane_offset_; }
  std::array<double, 3> u_axis() const { return {R_[0], R_[3], R_[6]}; }
  std::array<double, 3> v_axis() const { return {R_[1], R_[4], R_[7]}; }
  const std::array<double, 3>& origin() const { return t_; }
  double x_min() const { return x_min_; }
  double x_max() const { return x_max_; }
  double y_min() const { return y_min_; }
  double y_max() const { return y_max_; }

  const TargetSpec& spec() const { return *spec_; }

 private:
  const TargetSpec* spec_;
  std::array<double, 9> R_;  // row-major, camera <- target
  std::array<double, 3> t_;
  std::array<double, 3> n_;  // plane normal in the camera frame (R's third column)
  double plane_offset_;      // n . t
  double x_min_, x_max_, y_min_, y_max_;
  double edge_cos_ = 1, edge_sin_ = 0;  // slanted edge normal in target coordinates
  RegionValues dark_values() const;
  RegionValues light_values() const;

  // Dark and light reflectance by channel (kRed .. kGrey); a grey target answers every
  // channel with its grey values, exactly as a monochrome sensor sees it.
  double dark_[4] = {0, 0, 0, 0};
  double light_[4] = {0, 0, 0, 0};
  bool grey_ = true;
  std::shared_ptr<const cv::Mat> texture_;  // CV_32F grey reflectance over the extent
  std::shared_ptr<const CharucoPattern> charuco_;
  double texels_per_m_u_ = 0, texels_per_m_v_ = 0;
  // A channel's reflectance = offset + gain x the texture's grey value.
  double texture_offset_[4] = {0, 0, 0, 0};
  double texture_gain_[4] = {1, 1, 1, 1};
};

// The texture of a `texture` target: band-limited noise with features of about
// spec.feature_m, reflectance spanning [dark, light], deterministic in spec.texture_seed.
std::shared_ptr<const cv::Mat> make_texture(const TargetSpec& spec);

}  // namespace camlab::mock
