// Streaming focus-stack accumulator and the log-parabola peak.
#include "analysis/focus_stack.h"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <limits>
#include <numbers>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace camlab::analysis {
namespace {

// White-noise variance by Immerkaer's estimator (1996): the mask [1 -2 1; -2 4 -2; 1 -2 1]
// cancels locally quadratic image content, so smooth texture adds little; sigma =
// sqrt(pi/2) mean|image (x) mask| / 6. The Laplacian's floor is 20 sigma^2 (its kernel's
// squared norm). Taken as the least over a stack, the most defocused frame sets it.
// A global statistic: on large frames it is taken over bands of 32 rows every 128 rows
// (a quarter of the pixels), which leaves its precision far beyond what the floor needs.
double floor_of(const cv::Mat& image) {
  const cv::Matx33f mask(1, -2, 1, -2, 4, -2, 1, -2, 1);
  double sum = 0;
  double count = 0;
  const int band = image.rows > 512 ? 32 : image.rows, stride = image.rows > 512 ? 128 : image.rows;
  for (int y = 0; y < image.rows; y += stride) {
    const cv::Rect rows(0, y, image.cols, std::min(band, image.rows - y));
    cv::Mat r;
    cv::filter2D(image(rows), r, CV_32F, mask, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
    sum += cv::sum(cv::abs(r))[0];
    count += rows.area();
  }
  const double sigma = std::sqrt(std::numbers::pi / 2.0) * (sum / count) / 6.0;
  return 20.0 * sigma * sigma;
}

}  // namespace

namespace {

// BORDER_REFLECT index (fedcba|abcdefgh|hgfedcb) for n >= 1.
inline int reflect(int i, int n) {
  while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
  return i;
}

// One row of the squared Laplacian (reflected borders), then its horizontal box sum
// over 2 r + 1 columns (reflected), into `hsum` (doubles: running sums must not drift).
template <class T>
void laplacian_row_box_sum(const cv::Mat& image, int y, int r, std::vector<double>* sq_pad,
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

}  // namespace

// Fused: squared Laplacian, horizontal and vertical box sums in one pass over the rows,
// with a ring of the 2 r + 1 rows' horizontal sums (one read of the image, one write of
// the result; about 3x faster than three OpenCV passes on 12 MP).
cv::Mat focus_measure(const cv::Mat& image, int window_px) {
  const int w = std::max(1, window_px | 1), r = w / 2;
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F) {
    cv::Mat f;
    image.convertTo(f, CV_32F);
    return focus_measure(f, window_px);
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
      if (image.depth() == CV_8U) laplacian_row_box_sum<uint8_t>(image, real, r, &pad, &hrows[slot]);
      else if (image.depth() == CV_16U) laplacian_row_box_sum<uint16_t>(image, real, r, &pad, &hrows[slot]);
      else laplacian_row_box_sum<float>(image, real, r, &pad, &hrows[slot]);
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

double laplacian_noise_floor(const cv::Mat& image) { return floor_of(image); }

double log_parabola_delta(double minus, double centre, double plus) {
  if (!(minus > 0 && centre > 0 && plus > 0)) return 0.0;
  const double lm = std::log(minus), l0 = std::log(centre), lp = std::log(plus);
  const double curvature = lm - 2.0 * l0 + lp;
  if (!(curvature < 0)) return 0.0;  // not a peak
  return std::clamp((lm - lp) / (2.0 * curvature), -0.5, 0.5);
}

PeakFit fit_log_parabola_peak(const std::vector<double>& values, double floor, int peak_index) {
  PeakFit fit;
  fit.index = peak_index;
  const int n = static_cast<int>(values.size());
  if (peak_index <= 0 || peak_index >= n - 1) return fit;
  const double top = values[peak_index] - floor;
  if (!(top > 0)) return fit;
  const double eps = 1e-6 * top;
  int lo = peak_index - 1, hi = peak_index + 1;
  while (lo > 0 && values[lo - 1] - floor >= 0.5 * top) --lo;
  while (hi < n - 1 && values[hi + 1] - floor >= 0.5 * top) ++hi;
  fit.samples = hi - lo + 1;
  if (fit.samples == 3) {
    fit.index = peak_index + log_parabola_delta(std::max(values[lo] - floor, eps), top,
                                                std::max(values[hi] - floor, eps));
    return fit;
  }
  // Least squares l = a + b x + c x^2 with x = i - peak_index (normal equations, 3x3).
  cv::Matx33d ata = cv::Matx33d::zeros();
  cv::Vec3d atl(0, 0, 0);
  for (int i = lo; i <= hi; ++i) {
    const double x = i - peak_index, l = std::log(std::max(values[i] - floor, eps));
    const cv::Vec3d row(1.0, x, x * x);
    ata += row * row.t();
    atl += l * row;
  }
  cv::Matx33d inv;
  if (cv::invert(ata, inv, cv::DECOMP_CHOLESKY) == 0) return fit;
  const cv::Vec3d coef = inv * atl;
  const double b = coef[1], c = coef[2];
  if (!(c < 0)) return fit;
  const double vertex = -b / (2.0 * c);
  fit.index = peak_index + std::clamp(vertex, static_cast<double>(lo - peak_index),
                                      static_cast<double>(hi - peak_index));
  double ss = 0;
  for (int i = lo; i <= hi; ++i) {
    const double x = i - peak_index, l = std::log(std::max(values[i] - floor, eps));
    const double r = l - (coef[0] + b * x + c * x * x);
    ss += r * r;
  }
  if (fit.samples > 3) {
    const double s2 = ss / (fit.samples - 3);
    const double gb = -1.0 / (2.0 * c), gc = b / (2.0 * c * c);
    const double var = s2 * (gb * gb * inv(1, 1) + 2 * gb * gc * inv(1, 2) + gc * gc * inv(2, 2));
    fit.sigma = std::sqrt(std::max(0.0, var));
  }
  return fit;
}

double distance_at_index(const std::vector<double>& focus_distance_m, double index) {
  if (focus_distance_m.empty()) return std::numeric_limits<double>::infinity();
  const double last = static_cast<double>(focus_distance_m.size() - 1);
  const double i = std::clamp(index, 0.0, last);
  const size_t i0 = static_cast<size_t>(std::floor(i));
  const size_t i1 = std::min(i0 + 1, focus_distance_m.size() - 1);
  auto dioptres = [](double d) { return std::isfinite(d) && d > 0 ? 1.0 / d : 0.0; };
  const double t = i - static_cast<double>(i0);
  const double dpt = (1.0 - t) * dioptres(focus_distance_m[i0]) + t * dioptres(focus_distance_m[i1]);
  return dpt > 0 ? 1.0 / dpt : std::numeric_limits<double>::infinity();
}

Status FocusStackAccumulator::add(const cv::Mat& frame, double magnification) {
  if (finished_) return make_error("invalid_argument", "add() after finish()");
  if (frame.empty() || frame.channels() != 1)
    return make_error("invalid_argument", "focus-stack frames must be single-channel images");
  if (!(magnification > 0) || !std::isfinite(magnification))
    return make_error("invalid_argument", "magnification must be finite and > 0");
  if (count_ > 0 && (frame.size() != sharpest_.size() || frame.type() != sharpest_.type()))
    return make_error("invalid_argument", "focus-stack frames must share one size and type");
  // Region curves use the windowed measure's area means: equal to the squared
  // Laplacian's region means but for the window's r px at region borders, and it saves
  // a pass over the frame.
  const cv::Mat sq = focus_measure(frame, options_.window_px);
  // Brightness normalisation (header): 1 / mean^2, guarded for dark frames.
  auto inv_mean2 = [&](double mean_dn) {
    const double mean = mean_dn - options_.black_level;
    return 1.0 / std::max(mean * mean, 1e-6);
  };
  const double m2 = magnification * magnification;
  const double norm = inv_mean2(cv::mean(frame)[0]) * m2 * m2;
  const cv::Mat m = sq * norm;
  const double raw_floor = floor_of(frame);
  const double floor = raw_floor * norm;

  if (count_ == 0) {
    best_ = m.clone();
    best_minus_ = cv::Mat::zeros(m.size(), CV_32F);
    best_plus_ = cv::Mat::zeros(m.size(), CV_32F);
    best_index_ = cv::Mat::zeros(m.size(), CV_32S);
    sharpest_ = frame.clone();
    floor_ = floor;
    const int cell = std::max(4, options_.region_px);
    grid_ = cv::Size(m.cols / cell, m.rows / cell);
    for (int y = 0; y < grid_.height; ++y)
      for (int x = 0; x < grid_.width; ++x) region_rects_.emplace_back(x * cell, y * cell, cell, cell);
    region_curves_.assign(region_rects_.size(), {});
    region_floors_.assign(region_rects_.size(), std::numeric_limits<double>::infinity());
  } else {
    // One fused pass: the frame right after a pixel's best is its "plus" neighbour; a new
    // maximum takes the previous frame as its "minus" neighbour and this frame's pixel.
    const size_t elem = frame.elemSize();
    for (int r = 0; r < m.rows; ++r) {
      const float* mr = m.ptr<float>(r);
      const float* pr = previous_.ptr<float>(r);
      float* br = best_.ptr<float>(r);
      float* bm = best_minus_.ptr<float>(r);
      float* bp = best_plus_.ptr<float>(r);
      int* bi = best_index_.ptr<int>(r);
      const uint8_t* fr = frame.ptr<uint8_t>(r);
      uint8_t* sr = sharpest_.ptr<uint8_t>(r);
      for (int c = 0; c < m.cols; ++c) {
        if (bi[c] == count_ - 1) bp[c] = mr[c];
        if (mr[c] > br[c]) {
          bm[c] = pr[c];
          br[c] = mr[c];
          bi[c] = count_;
          std::memcpy(sr + c * elem, fr + c * elem, elem);
        }
      }
    }
    floor_ = std::min(floor_, floor);  // the quietest frame's floor
  }
  // Region means of the squared Laplacian and of the signal, by area averaging over the
  // grid (exact: whole cells).
  if (!region_rects_.empty()) {
    const int cell = region_rects_[0].width;
    const cv::Rect cover(0, 0, grid_.width * cell, grid_.height * cell);
    cv::Mat sq_means, signal, signal_means;
    cv::resize(sq(cover), sq_means, grid_, 0, 0, cv::INTER_AREA);
    frame(cover).convertTo(signal, CV_32F);
    cv::resize(signal, signal_means, grid_, 0, 0, cv::INTER_AREA);
    for (size_t k = 0; k < region_rects_.size(); ++k) {
      const int gx = static_cast<int>(k) % grid_.width, gy = static_cast<int>(k) / grid_.width;
      const double rn = inv_mean2(signal_means.at<float>(gy, gx)) * m2 * m2;
      region_curves_[k].push_back(sq_means.at<float>(gy, gx) * rn);
      region_floors_[k] = std::min(region_floors_[k], raw_floor * rn);
    }
  }
  previous_ = m;
  ++count_;
  return {};
}

Result<FocusStackResult> FocusStackAccumulator::finish() {
  if (finished_) return make_error("invalid_argument", "finish() called twice");
  if (count_ < 3)
    return make_error("too_few_samples", "a focus stack needs at least 3 frames; got " +
                                             std::to_string(count_));
  finished_ = true;
  const double floor = floor_;
  FocusStackResult out;
  out.frames = count_;
  out.best_index.create(best_.size(), CV_32F);
  out.valid = cv::Mat::zeros(best_.size(), CV_8U);
  for (int r = 0; r < best_.rows; ++r) {
    const float* b = best_.ptr<float>(r);
    const float* bm = best_minus_.ptr<float>(r);
    const float* bp = best_plus_.ptr<float>(r);
    const int* bi = best_index_.ptr<int>(r);
    float* oi = out.best_index.ptr<float>(r);
    uint8_t* ov = out.valid.ptr<uint8_t>(r);
    for (int c = 0; c < best_.cols; ++c) {
      const bool inside = bi[c] > 0 && bi[c] < count_ - 1;
      const bool above = b[c] - floor > options_.min_peak_ratio * floor;
      double delta = 0;
      if (inside && above) {
        const double eps = 1e-6 * (b[c] - floor);
        delta = log_parabola_delta(std::max<double>(bm[c] - floor, eps),
                                   b[c] - floor, std::max<double>(bp[c] - floor, eps));
        ov[c] = 255;
      }
      oi[c] = static_cast<float>(bi[c] + delta);
    }
  }
  out.all_in_focus = sharpest_;
  for (size_t k = 0; k < region_rects_.size(); ++k) {
    RegionFocus rf;
    rf.rect = region_rects_[k];
    rf.curve = region_curves_[k];
    const double region_floor = region_floors_[k];
    const auto peak = std::max_element(rf.curve.begin(), rf.curve.end());
    const int i = static_cast<int>(peak - rf.curve.begin());
    const double least = *std::min_element(rf.curve.begin(), rf.curve.end());
    rf.best_index = i;
    rf.confidence = region_floor > 0 ? (*peak - region_floor) / region_floor : std::numeric_limits<double>::max();
    if (*peak - region_floor <= options_.min_peak_ratio * region_floor || *peak < 1.25 * least) {
      rf.status = kFocusFlat;
      rf.confidence = 0;
    } else if (i == 0 || i == count_ - 1) {
      rf.status = kFocusPeakAtEnd;
    } else {
      const PeakFit pf = fit_log_parabola_peak(rf.curve, region_floor, i);
      rf.best_index = pf.index;
      rf.best_index_sigma = pf.sigma;
      rf.status = kFocusOk;
    }
    out.regions.push_back(std::move(rf));
  }
  return out;
}

}  // namespace camlab::analysis
