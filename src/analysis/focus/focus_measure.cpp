// The per-pixel focus measure (squared Laplacian, box-averaged) and its noise floor
// (focus_stack.h). Speed matters here: a focus stack runs it on every frame, 12 MP and
// up. This file is compiled with GCC's dynamic vectorizer cost model
// (src/analysis/CMakeLists.txt): at -O2 GCC 12 vectorizes only loops whose trip count
// needs no scalar tail, which leaves every row loop below scalar.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/focus/focus_stack.h"

namespace camlab::analysis {
namespace {

// BORDER_REFLECT index (fedcba|abcdefgh|hgfedcb) for n >= 1.
inline int reflect(int i, int n) {
  while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
  return i;
}

// The squared Laplacian of image row y (reflected borders), in float as OpenCV's
// Laplacian + multiply give it, written to `slot` while the column sums `vsum` take it
// in (and give up the row `slot` held: the window's row leaving as this one enters).
// vsum is in double: for integer images every squared Laplacian is an integer below
// 2^37, so these running sums are exact and cannot drift over thousands of rows.
template <class T, bool kFirst>
void laplacian_row(const cv::Mat& image, int y, float* slot, double* vsum) {
  const int w = image.cols, h = image.rows;
  const T* up = image.ptr<T>(reflect(y - 1, h));
  const T* mid = image.ptr<T>(y);
  const T* down = image.ptr<T>(reflect(y + 1, h));
  auto lap2 = [&](int x, int xl, int xr) {
    const float v = static_cast<float>(up[x]) + static_cast<float>(down[x]) +
                    static_cast<float>(mid[xl]) + static_cast<float>(mid[xr]) -
                    4.0f * static_cast<float>(mid[x]);
    return v * v;
  };
  auto put = [&](int x, float v) {
    vsum[x] +=
        kFirst ? static_cast<double>(v) : static_cast<double>(v) - static_cast<double>(slot[x]);
    slot[x] = v;
  };
  put(0, lap2(0, 0, w > 1 ? 1 : 0));
  for (int x = 1; x < w - 1; ++x) put(x, lap2(x, x - 1, x + 1));  // no clamps: vectorises
  if (w > 1) put(w - 1, lap2(w - 1, w - 2, w - 1));
}

// Output rows [y0, y1): a ring of the window's 2r + 1 squared-Laplacian rows, their
// column sums, then the row's horizontal box sum.
template <class T>
void measure_rows(const cv::Mat& image, int r, int y0, int y1, float scale, cv::Mat* out) {
  const int w = image.cols, h = image.rows, n = 2 * r + 1, len = w + 2 * r;
  std::vector<float> ring(static_cast<size_t>(n) * w), pad(len), run(len), acc(w);
  std::vector<double> vsum(w, 0.0);
  // Ring slots are indexed by the virtual row y + k (before reflection), so the row
  // leaving the window and the one entering it share a slot.
  auto slot = [&](int virtual_row) {
    return ring.data() + static_cast<size_t>(((virtual_row % n) + n) % n) * w;
  };
  for (int k = -r; k <= r; ++k)
    laplacian_row<T, true>(image, reflect(y0 + k, h), slot(y0 + k), vsum.data());
  for (int y = y0; y < y1; ++y) {
    float* o = out->ptr<float>(y);
    float* p = pad.data() + r;  // p[-r .. w - 1 + r]
    for (int x = 0; x < w; ++x) p[x] = static_cast<float>(vsum[x]);
    for (int k = 1; k <= r; ++k) {
      p[-k] = p[reflect(-k, w)];
      p[w - 1 + k] = p[reflect(w - 1 + k, w)];
    }
    if (r <= 16) {
      // n taps from sums over runs of 2^j: run_2m[x] = run_m[x] + run_m[x + m], and the
      // binary digits of n pick the runs to add (9 taps: 3 doublings and 2 adds instead
      // of 8 adds, each a vectorised pass over the row). n is odd, so the 1-tap run (the
      // padded row itself) always starts the sum. All terms are >= 0, so the float sums
      // stay within ~1e-6 of the exact value, relative to the result.
      int top = 1;
      while (2 * top <= n) top *= 2;
      const float* q = pad.data();
      if (top == 1)
        for (int x = 0; x < w; ++x) o[x] = q[x] * scale;
      const float* cur = q;
      const float* sum = q;  // the runs added so far (q alone at first)
      int offset = 1;
      for (int m = 2; m <= top; m *= 2) {
        const int half = m / 2;
        float* next = run.data();
        for (int x = 0; x + half < len; ++x) next[x] = cur[x] + cur[x + half];
        cur = next;
        if (!(n & m)) continue;
        const float* add = cur + offset;
        if (m == top) {
          for (int x = 0; x < w; ++x) o[x] = (sum[x] + add[x]) * scale;
        } else {
          for (int x = 0; x < w; ++x) acc[x] = sum[x] + add[x];
          sum = acc.data();
          offset += m;
        }
      }
    } else {
      // Wide windows: a running sum in double (sequential, but O(1) per pixel).
      double sum = 0;
      for (int k = -r; k <= r; ++k) sum += p[k];
      for (int x = 0; x < w; ++x) {
        o[x] = static_cast<float>(sum * scale);
        sum += static_cast<double>(p[x + r + 1 < w + r ? x + r + 1 : w - 1 + r]) - p[x - r];
      }
    }
    if (y + 1 < y1)
      laplacian_row<T, false>(image, reflect(y + r + 1, h), slot(y + r + 1), vsum.data());
  }
}

}  // namespace

void focus_measure(const cv::Mat& image, int window_px, cv::Mat* out, double scale) {
  const int w = std::max(1, window_px | 1), r = w / 2;
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F) {
    cv::Mat f;
    image.convertTo(f, CV_32F);
    focus_measure(f, window_px, out, scale);
    return;
  }
  out->create(image.size(), CV_32F);
  const float factor = static_cast<float>(scale / (static_cast<double>(w) * w));
  // Horizontal stripes on OpenCV's threads (each stripe sets up its own window: 2r rows
  // of extra work), at most one per thread and never thinner than 8 windows.
  const int stripes = std::clamp(std::min(cv::getNumThreads(), image.rows / (8 * w)), 1, 16);
  auto body = [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      const int y0 = static_cast<int>(static_cast<long>(image.rows) * s / stripes);
      const int y1 = static_cast<int>(static_cast<long>(image.rows) * (s + 1) / stripes);
      if (image.depth() == CV_8U)
        measure_rows<uint8_t>(image, r, y0, y1, factor, out);
      else if (image.depth() == CV_16U)
        measure_rows<uint16_t>(image, r, y0, y1, factor, out);
      else
        measure_rows<float>(image, r, y0, y1, factor, out);
    }
  };
  if (stripes > 1)
    cv::parallel_for_(cv::Range(0, stripes), body, stripes);
  else
    body(cv::Range(0, 1));
}

cv::Mat focus_measure(const cv::Mat& image, int window_px) {
  cv::Mat out;
  focus_measure(image, window_px, &out, 1.0);
  return out;
}

// White-noise variance by Immerkaer's estimator (1996): the mask [1 -2 1; -2 4 -2; 1 -2 1]
// cancels locally quadratic image content, so smooth texture adds little; sigma =
// sqrt(pi/2) mean|image (x) mask| / 6. The Laplacian's floor is 20 sigma^2 (its kernel's
// squared norm). Taken as the least over a stack, the most defocused frame sets it.
// A global statistic: on large frames it is taken over bands of 32 rows every 128 rows
// (a quarter of the pixels), which leaves its precision far beyond what the floor needs.
double laplacian_noise_floor(const cv::Mat& image) {
  const cv::Matx33f mask(1, -2, 1, -2, 4, -2, 1, -2, 1);
  double sum = 0;
  double count = 0;
  const int band = image.rows > 512 ? 32 : image.rows, stride = image.rows > 512 ? 128 : image.rows;
  for (int y = 0; y < image.rows; y += stride) {
    const cv::Rect rows(0, y, image.cols, std::min(band, image.rows - y));
    cv::Mat r;
    cv::filter2D(image(rows), r, CV_32F, mask, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
    sum += cv::norm(r, cv::NORM_L1);
    count += rows.area();
  }
  const double sigma = std::sqrt(std::numbers::pi / 2.0) * (sum / count) / 6.0;
  return 20.0 * sigma * sigma;
}

}  // namespace camlab::analysis
