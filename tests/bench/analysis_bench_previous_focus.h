// The focus measure as it was before its speed-up (src/analysis/focus/focus_stack.cpp,
// 2026-11-21): one fused pass with double running sums, horizontal sums sequential.
// Kept only so analysis_bench can time the current measure against it in the same run
// (docs/measuring.md: compare two methods as a ratio measured in the same run).
#pragma once

#include <algorithm>
#include <vector>

#include <opencv2/core.hpp>

namespace camlab::bench::previous {

// BORDER_REFLECT index (fedcba|abcdefgh|hgfedcb) for n >= 1.
inline int reflect(int i, int n) {
  while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
  return i;
}

// One row of the squared Laplacian (reflected borders), then its horizontal box sum
// over 2 r + 1 columns (reflected), into `hsum` (doubles: running sums must not drift).
template <class T>
inline void laplacian_row_box_sum(const cv::Mat& image, int y, int r, std::vector<double>* sq_pad,
                                  std::vector<double>* hsum) {
  const int w = image.cols, h = image.rows;
  const T* up = image.ptr<T>(reflect(y - 1, h));
  const T* mid = image.ptr<T>(y);
  const T* down = image.ptr<T>(reflect(y + 1, h));
  double* pad = sq_pad->data() + r;  // pad[-r .. w - 1 + r]
  auto at = [&](int x, int xl, int xr) {
    const float v = static_cast<float>(up[x]) + static_cast<float>(down[x]) +
                    static_cast<float>(mid[xl]) + static_cast<float>(mid[xr]) -
                    4.0f * static_cast<float>(mid[x]);
    return static_cast<double>(v * v);
  };
  pad[0] = at(0, 0, w > 1 ? 1 : 0);
  for (int x = 1; x < w - 1; ++x) pad[x] = at(x, x - 1, x + 1);  // no clamps: vectorises
  if (w > 1) pad[w - 1] = at(w - 1, w - 2, w - 1);
  for (int k = 1; k <= r; ++k) {
    pad[-k] = pad[reflect(-k, w)];
    pad[w - 1 + k] = pad[reflect(w - 1 + k, w)];
  }
  double run = 0;
  for (int k = -r; k <= r; ++k) run += pad[k];
  double* out = hsum->data();
  for (int x = 0; x < w; ++x) {
    out[x] = run;
    run += pad[x + r + 1 < w + r ? x + r + 1 : w - 1 + r] - pad[x - r];
  }
}

// Fused: squared Laplacian, horizontal and vertical box sums in one pass over the rows,
// with a ring of the 2 r + 1 rows' horizontal sums (one read of the image, one write of
// the result; about 3x faster than three OpenCV passes on 12 MP).
inline cv::Mat previous_focus_measure(const cv::Mat& image, int window_px) {
  const int w = std::max(1, window_px | 1), r = w / 2;
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F) {
    cv::Mat f;
    image.convertTo(f, CV_32F);
    return previous_focus_measure(f, window_px);
  }
  const int cols = image.cols, rows = image.rows;
  cv::Mat out(rows, cols, CV_32F);
  const int ring = w + 1;
  std::vector<std::vector<double>> hrows(ring, std::vector<double>(cols));
  std::vector<int> tag(ring, -1);
  std::vector<double> pad(cols + 2 * r + 1), acc(cols, 0.0);
  auto row_sum = [&](int real) -> const std::vector<double>& {
    const int slot = real % ring;
    if (tag[slot] != real) {
      if (image.depth() == CV_8U)
        laplacian_row_box_sum<uint8_t>(image, real, r, &pad, &hrows[slot]);
      else if (image.depth() == CV_16U)
        laplacian_row_box_sum<uint16_t>(image, real, r, &pad, &hrows[slot]);
      else
        laplacian_row_box_sum<float>(image, real, r, &pad, &hrows[slot]);
      tag[slot] = real;
    }
    return hrows[slot];
  };
  for (int k = -r; k <= r; ++k) {
    const std::vector<double>& h = row_sum(reflect(k, rows));
    for (int x = 0; x < cols; ++x) acc[x] += h[x];
  }
  const double scale = 1.0 / (static_cast<double>(w) * w);
  for (int y = 0; y < rows; ++y) {
    float* o = out.ptr<float>(y);
    for (int x = 0; x < cols; ++x) o[x] = static_cast<float>(acc[x] * scale);
    if (y + 1 == rows) break;
    const std::vector<double>& add = row_sum(reflect(y + r + 1, rows));
    const std::vector<double>& sub = row_sum(reflect(y - r, rows));
    for (int x = 0; x < cols; ++x) acc[x] += add[x] - sub[x];
  }
  return out;
}

}  // namespace camlab::bench::previous
