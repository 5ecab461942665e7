// What the single-edge fit (edge_spread.cpp) and the edge-pair fit (edge_pair.cpp) share
// apart from the damping loop (levenberg_marquardt.h): the check that an image can be
// fitted, the pixels of a window laid along a line, and the normal equations with their
// damped and pinned solves.
//
// Conventions: pixel centres at integers; a line's direction is (cos a, sin a) and its
// normal (-sin a, cos a), as in edge_spread.h.
// Reentrant: no state.
#pragma once

#include <algorithm>
#include <array>
#include <bitset>
#include <cmath>
#include <cstddef>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"

namespace camlab::analysis::edge_fit {

// Ok when `image` is a non-empty single-channel CV_8U, CV_16U, CV_32F or CV_64F matrix;
// otherwise invalid_argument saying so.
Status check_fittable_image(const cv::Mat& image);

// A window laid along a line through (x_px, y_px) at angle_rad: |along| <= half_length_px
// and across_min_px <= across <= across_max_px, along and across measured from that point.
struct LineWindow {
  double x_px = 0, y_px = 0, angle_rad = 0;
  double half_length_px = 0;
  double across_min_px = 0, across_max_px = 0;
};

// One pixel inside a window: its centre, its value (as double) and its signed distance
// across the window's line.
struct WindowPixel {
  int col = 0, row = 0;
  double value = 0;
  double across_px = 0;
};

// The window's pixels with a finite value, row by row. window_outside_image when the
// window's bounding box reaches beyond the image's pixel centres (`window_name` starts the
// message, e.g. "the fit window"), so that every pixel the window covers exists.
Result<std::vector<WindowPixel>> sample_window(const cv::Mat& image, const LineWindow& window,
                                               std::string_view window_name);

// The normal equations of a least-squares fit of N parameters: cost = sum r^2,
// jtj = J^T J (row-major N x N), jtr = J^T r, for residuals r = value - model and
// J = d model / d params.
template <std::size_t N>
struct NormalEquations {
  double cost = 0;
  std::array<double, N * N> jtj{};
  std::array<double, N> jtr{};

  // Adds one sample's Jacobian row and residual (the lower triangle of jtj only).
  void add(const std::array<double, N>& row, double residual) {
    cost += residual * residual;
    for (std::size_t i = 0; i < N; ++i) {
      jtr[i] += row[i] * residual;
      for (std::size_t j = 0; j <= i; ++j) jtj[i * N + j] += row[i] * row[j];
    }
  }
  // Mirrors the lower triangle once all samples are added.
  void symmetrise() {
    for (std::size_t i = 0; i < N; ++i)
      for (std::size_t j = i + 1; j < N; ++j) jtj[i * N + j] = jtj[j * N + i];
  }
};

// (J^T J + lambda diag(J^T J)) step = J^T r by Cholesky (Marquardt's scaling: levels in DN
// and lengths in px differ by orders of magnitude). A `pinned` parameter, and one whose
// column is zero (a diameter at exactly 0, where the model's slope vanishes), keeps its
// value: its row and column become the identity, so the rest is unaffected. False when
// the system is singular or the step not finite.
template <std::size_t N>
bool solve_damped(const NormalEquations<N>& normals, double lambda, std::bitset<N> pinned,
                  std::array<double, N>* step) {
  std::array<double, N* N> a = normals.jtj;
  std::array<double, N> rhs = normals.jtr;
  for (std::size_t i = 0; i < N; ++i) {
    if (!pinned[i]) continue;
    for (std::size_t j = 0; j < N; ++j) a[i * N + j] = a[j * N + i] = 0.0;
    rhs[i] = 0.0;
  }
  for (std::size_t i = 0; i < N; ++i) {
    double& diagonal = a[i * N + i];
    diagonal *= 1.0 + lambda;
    if (diagonal == 0.0) diagonal = 1.0;
  }
  constexpr int kSize = static_cast<int>(N);
  cv::Mat x(kSize, 1, CV_64F, step->data());
  if (!cv::solve(cv::Mat(kSize, kSize, CV_64F, a.data()), cv::Mat(kSize, 1, CV_64F, rhs.data()), x,
                 cv::DECOMP_CHOLESKY)) {
    return false;
  }
  return std::all_of(step->begin(), step->end(), [](double v) { return std::isfinite(v); });
}

// (J^T J)^-1 by Cholesky, the covariance up to the residual variance. Only `pinned`
// parameters become the identity: a parameter the data say nothing about shows as a
// singular matrix (false), not as a zero variance.
template <std::size_t N>
bool invert_normals(const NormalEquations<N>& normals, std::bitset<N> pinned, cv::Mat* inverse) {
  std::array<double, N* N> a = normals.jtj;
  for (std::size_t i = 0; i < N; ++i) {
    if (!pinned[i]) continue;
    for (std::size_t j = 0; j < N; ++j) a[i * N + j] = a[j * N + i] = 0.0;
    a[i * N + i] = 1.0;
  }
  constexpr int kSize = static_cast<int>(N);
  return cv::invert(cv::Mat(kSize, kSize, CV_64F, a.data()), *inverse, cv::DECOMP_CHOLESKY) != 0.0;
}

}  // namespace camlab::analysis::edge_fit
