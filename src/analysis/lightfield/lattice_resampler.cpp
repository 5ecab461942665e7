#include "analysis/lightfield/lattice_resampler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

namespace camlab::analysis::lightfield {

namespace {

// The taps (indices clamped to the image) and weights of an interpolation at x (pixel
// centres at integers) over n samples: Lanczos-3, sinc(s) sinc(s / 3) over |s| < 3,
// normalised to sum to 1.
constexpr int kTaps = 6;
struct Taps {
  std::array<int, kTaps> index;
  std::array<float, kTaps> weight;
};

Taps taps_at(double x, int n) {
  const double x0 = std::floor(x);
  const double t = x - x0;
  Taps taps;
  const long base = static_cast<long>(x0) - kTaps / 2 + 1;
  double w[kTaps], sum = 0;
  for (int k = 0; k < kTaps; ++k) {
    const double s = t + kTaps / 2 - 1 - k;  // distance from tap k
    if (std::fabs(s) < 1e-12) {
      w[k] = 1;
    } else {
      const double p = std::numbers::pi * s;
      w[k] = 3 * std::sin(p) * std::sin(p / 3) / (p * p);
    }
    sum += w[k];
  }
  for (int k = 0; k < kTaps; ++k) {
    taps.index[static_cast<size_t>(k)] =
        static_cast<int>(std::clamp<long>(base + k, 0, static_cast<long>(n) - 1));
    taps.weight[static_cast<size_t>(k)] = static_cast<float>(w[k] / sum);
  }
  return taps;
}

}  // namespace

LatticeResampler::LatticeResampler(const image::ViewLattice& lattice, cv::Size view_size,
                                   cv::Size out_size)
    : lattice_(lattice), view_size_(view_size), out_size_(out_size) {}

cv::Size LatticeResampler::square_grid_size(const image::ViewLattice& lattice, cv::Size view_size) {
  const int rows =
      static_cast<int>(std::floor((view_size.height - 1) * lattice.row_pitch + 1e-9)) + 1;
  return {view_size.width, std::max(1, rows)};
}

void LatticeResampler::accumulate(const cv::Mat& view, double scale, double offset_x,
                                  double offset_y, float weight, cv::Mat& out) {
  CV_Assert(view.type() == CV_32F && view.size() == view_size_);
  CV_Assert(out.type() == CV_32F && out.size() == out_size_);
  const int width = view_size_.width, height = view_size_.height;
  const bool staggered = lattice_.odd_row_shift != 0;
  // Column taps per row parity: a row's pixel k sits at x = k + its shift.
  std::vector<Taps> columns[2];
  for (int parity = 0; parity < (staggered ? 2 : 1); ++parity) {
    const double shift = parity == 1 ? lattice_.odd_row_shift : 0.0;
    columns[parity].resize(static_cast<size_t>(out_size_.width));
    for (int i = 0; i < out_size_.width; ++i)
      columns[parity][static_cast<size_t>(i)] = taps_at(scale * i + offset_x - shift, width);
  }
  // The lattice rows the output rows reach.
  std::vector<Taps> rows(static_cast<size_t>(out_size_.height));
  int row_lo = height, row_hi = -1;
  for (int j = 0; j < out_size_.height; ++j) {
    Taps& t = rows[static_cast<size_t>(j)];
    t = taps_at((scale * j + offset_y) / lattice_.row_pitch, height);
    row_lo = std::min(row_lo, t.index[0]);
    row_hi = std::max(row_hi, t.index[kTaps - 1]);
  }
  rows_.create(height, out_size_.width, CV_32F);
  for (int parity = 0; parity < (staggered ? 2 : 1); ++parity) {
    const std::vector<Taps>& taps = columns[parity];
    // Without magnification every column has the same weights at consecutive taps: the
    // columns whose taps are not clamped are one FIR (contiguous, vectorised), the ends
    // the general gather. The result is the same, term for term.
    int fir_lo = out_size_.width, fir_hi = -1;
    if (scale == 1.0) {
      for (int i = 0; i < out_size_.width; ++i) {
        const Taps& t = taps[static_cast<size_t>(i)];
        if (t.index[kTaps - 1] - t.index[0] == kTaps - 1 && (fir_hi < 0 || i == fir_hi + 1)) {
          fir_lo = std::min(fir_lo, i);
          fir_hi = i;
        }
      }
    }
    for (int l = row_lo + ((row_lo % 2 != parity) && staggered ? 1 : 0); l <= row_hi;
         l += staggered ? 2 : 1) {
      const float* __restrict in = view.ptr<float>(l);
      float* __restrict dst = rows_.ptr<float>(l);
      for (int i = 0; i < out_size_.width; ++i) {
        if (i == fir_lo) {
          const Taps& t = taps[static_cast<size_t>(fir_lo)];
          const float* __restrict src = in + t.index[0] - fir_lo;
          const float w0 = t.weight[0], w1 = t.weight[1], w2 = t.weight[2], w3 = t.weight[3],
                      w4 = t.weight[4], w5 = t.weight[5];
          for (int j = fir_lo; j <= fir_hi; ++j)
            dst[j] = w0 * src[j] + w1 * src[j + 1] + w2 * src[j + 2] + w3 * src[j + 3] +
                     w4 * src[j + 4] + w5 * src[j + 5];
          i = fir_hi;
          continue;
        }
        const Taps& t = taps[static_cast<size_t>(i)];
        float v = 0;
        for (int k = 0; k < kTaps; ++k) v += t.weight[k] * in[t.index[k]];
        dst[i] = v;
      }
    }
  }
  for (int j = 0; j < out_size_.height; ++j) {
    const Taps& t = rows[static_cast<size_t>(j)];
    float* __restrict dst = out.ptr<float>(j);
    const float* __restrict r0 = rows_.ptr<float>(t.index[0]);
    const float* __restrict r1 = rows_.ptr<float>(t.index[1]);
    const float* __restrict r2 = rows_.ptr<float>(t.index[2]);
    const float* __restrict r3 = rows_.ptr<float>(t.index[3]);
    const float* __restrict r4 = rows_.ptr<float>(t.index[4]);
    const float* __restrict r5 = rows_.ptr<float>(t.index[5]);
    const float w0 = weight * t.weight[0], w1 = weight * t.weight[1], w2 = weight * t.weight[2],
                w3 = weight * t.weight[3], w4 = weight * t.weight[4], w5 = weight * t.weight[5];
    for (int i = 0; i < out_size_.width; ++i)
      dst[i] += w0 * r0[i] + w1 * r1[i] + w2 * r2[i] + w3 * r3[i] + w4 * r4[i] + w5 * r5[i];
  }
}

cv::Mat LatticeResampler::resample(const cv::Mat& view, double scale, double offset_x,
                                   double offset_y) {
  cv::Mat out(out_size_, CV_32F, cv::Scalar(0));
  accumulate(view, scale, offset_x, offset_y, 1.0f, out);
  return out;
}

}  // namespace camlab::analysis::lightfield
