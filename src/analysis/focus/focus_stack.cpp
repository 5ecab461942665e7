// Streaming focus-stack accumulator and the log-parabola peak.
#include "analysis/focus/focus_stack.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <type_traits>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace camlab::analysis {
namespace {

// Sums of `image` over each cell x cell region of a grid (whole cells from the top-left),
// row-major: one pass, no converted copy of the frame. Integer pixels sum exactly in
// 64 bits; floating ones in four interleaved double sums (independent additions).
template <class T>
void region_sums(const cv::Mat& image, int cell, cv::Size grid, std::vector<double>* sums) {
  using Acc = std::conditional_t<std::is_integral_v<T>, int64_t, double>;
  sums->assign(static_cast<size_t>(grid.area()), 0.0);
  for (int y = 0; y < grid.height * cell; ++y) {
    const T* row = image.ptr<T>(y);
    double* out = sums->data() + static_cast<size_t>(y / cell) * grid.width;
    for (int gx = 0; gx < grid.width; ++gx) {
      const T* p = row + gx * cell;
      Acc s[4] = {0, 0, 0, 0};
      int k = 0;
      for (; k + 4 <= cell; k += 4) {
        s[0] += p[k];
        s[1] += p[k + 1];
        s[2] += p[k + 2];
        s[3] += p[k + 3];
      }
      for (; k < cell; ++k) s[0] += p[k];
      out[gx] += static_cast<double>(s[0] + s[1]) + static_cast<double>(s[2] + s[3]);
    }
  }
}

void region_means(const cv::Mat& image, int cell, cv::Size grid, std::vector<double>* means) {
  switch (image.depth()) {
    case CV_8U:
      region_sums<uint8_t>(image, cell, grid, means);
      break;
    case CV_16U:
      region_sums<uint16_t>(image, cell, grid, means);
      break;
    case CV_32F:
      region_sums<float>(image, cell, grid, means);
      break;
    default: {
      cv::Mat f;
      image.convertTo(f, CV_64F);
      region_sums<double>(f, cell, grid, means);
    }
  }
  for (double& m : *means) m /= static_cast<double>(cell) * cell;
}

}  // namespace

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

namespace {

// Mirror residuals of l about m: l(x_i) - l_interpolated(2m - x_i) for the kept samples
// whose mirror lies inside the curve, and the slope of the interpolation there.
struct Mirror {
  double cost = 0;
  int count = 0;
  double slope_sum2 = 0;
};

Mirror mirror_about(const std::vector<double>& l, const std::vector<int>& kept, double m) {
  Mirror out;
  const int n = static_cast<int>(l.size());
  for (int i : kept) {
    const double x = 2 * m - i;
    if (x < 0 || x > n - 1) continue;
    const int j = std::min(static_cast<int>(std::floor(x)), n - 2);
    const double t = x - j, slope = l[static_cast<size_t>(j) + 1] - l[static_cast<size_t>(j)];
    const double r = l[static_cast<size_t>(i)] - (l[static_cast<size_t>(j)] + t * slope);
    out.cost += r * r;
    out.slope_sum2 += 4 * slope * slope;  // d r / d m = -2 slope
    ++out.count;
  }
  return out;
}

}  // namespace

PeakFit fit_symmetric_peak(const std::vector<double>& values, double floor, int peak_index) {
  PeakFit fit;
  fit.index = peak_index;
  const int n = static_cast<int>(values.size());
  if (peak_index <= 0 || peak_index >= n - 1) return fit;
  const double top = values[static_cast<size_t>(peak_index)] - floor;
  if (!(top > 0) || !std::isfinite(top)) return fit;
  std::vector<double> l(values.size());
  std::vector<int> kept;
  for (int i = 0; i < n; ++i) {
    const double excess = values[static_cast<size_t>(i)] - floor;
    l[static_cast<size_t>(i)] = std::log(std::max(excess, 1e-12 * top));
    if (excess >= 0.1 * top) kept.push_back(i);
  }
  // The mirror cost is not convex in m (linear interpolation has kinks): scan the step
  // either side of the maximum at 0.01, then refine around the best at 0.0002.
  auto best_in = [&](double from, double to, double step) {
    double best_m = peak_index, best_cost = std::numeric_limits<double>::infinity();
    for (double m = from; m <= to + 1e-12; m += step) {
      const Mirror mm = mirror_about(l, kept, m);
      if (mm.count < 3) continue;
      const double cost = mm.cost / mm.count;
      if (cost < best_cost) best_cost = cost, best_m = m;
    }
    return std::pair{best_m, best_cost};
  };
  auto [coarse, coarse_cost] = best_in(peak_index - 1.0, peak_index + 1.0, 0.01);
  if (!std::isfinite(coarse_cost)) return fit;
  const double m = best_in(coarse - 0.01, coarse + 0.01, 0.0002).first;
  const Mirror at = mirror_about(l, kept, m);
  fit.index = m;
  fit.samples = at.count;
  const double s2 = at.count > 1 ? at.cost / (at.count - 1) : 0.0;
  const double sigma = at.slope_sum2 > 0 ? std::sqrt(s2 / at.slope_sum2) : 0.0;
  fit.sigma = std::max(kMinPeakSigma, std::isfinite(sigma) ? sigma : 1.0);
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
  const double dpt =
      (1.0 - t) * dioptres(focus_distance_m[i0]) + t * dioptres(focus_distance_m[i1]);
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
  // Brightness normalisation (header): 1 / mean^2, guarded for dark frames, applied
  // while the measure is written (into a buffer reused from frame to frame).
  auto inv_mean2 = [&](double mean_dn) {
    const double mean = mean_dn - options_.black_level;
    return 1.0 / std::max(mean * mean, 1e-6);
  };
  const double m2 = magnification * magnification;
  const double norm = inv_mean2(cv::mean(frame)[0]) * m2 * m2;
  focus_measure(frame, options_.window_px, &scratch_, norm);
  const cv::Mat& m = scratch_;
  const double raw_floor = laplacian_noise_floor(frame);
  const double floor = raw_floor * norm;

  if (count_ == 0) {
    best_ = m.clone();
    previous_.create(m.size(), CV_32F);
    best_minus_ = cv::Mat::zeros(m.size(), CV_32F);
    best_plus_ = cv::Mat::zeros(m.size(), CV_32F);
    best_index_ = cv::Mat::zeros(m.size(), CV_32S);
    sharpest_ = frame.clone();
    floor_ = floor;
    const int cell = std::max(4, options_.region_px);
    grid_ = cv::Size(m.cols / cell, m.rows / cell);
    for (int y = 0; y < grid_.height; ++y)
      for (int x = 0; x < grid_.width; ++x)
        region_rects_.emplace_back(x * cell, y * cell, cell, cell);
    region_curves_.assign(region_rects_.size(), {});
    region_floors_.assign(region_rects_.size(), std::numeric_limits<double>::infinity());
  } else {
    // One fused pass: the frame right after a pixel's best is its "plus" neighbour; a new
    // maximum takes the previous frame as its "minus" neighbour and this frame's pixel.
    switch (frame.elemSize()) {
      case 1:
        update_peaks<uint8_t>(m, frame);
        break;
      case 2:
        update_peaks<uint16_t>(m, frame);
        break;
      case 4:
        update_peaks<uint32_t>(m, frame);
        break;
      default:
        update_peaks<uint64_t>(m, frame);
        break;  // CV_64F (8 bytes)
    }
    floor_ = std::min(floor_, floor);  // the quietest frame's floor
  }
  // Region means of the (windowed) squared Laplacian and of the signal, over whole
  // cells. The windowed measure's region means equal the squared Laplacian's but for the
  // window's r px at region borders, and they save a pass over the frame.
  if (!region_rects_.empty()) {
    const int cell = region_rects_[0].width;
    std::vector<double> measure_means, signal_means;
    region_means(m, cell, grid_, &measure_means);
    region_means(frame, cell, grid_, &signal_means);
    for (size_t k = 0; k < region_rects_.size(); ++k) {
      const double rn = inv_mean2(signal_means[k]) * m2 * m2;
      region_curves_[k].push_back(measure_means[k] / norm * rn);
      region_floors_[k] = std::min(region_floors_[k], raw_floor * rn);
    }
  }
  std::swap(previous_, scratch_);  // this frame's measure is the next one's "previous"
  ++count_;
  return {};
}

// Pixels are copied as opaque words of the frame's element size (a typed copy, not a
// memcpy call per pixel).
template <class Word>
void FocusStackAccumulator::update_peaks(const cv::Mat& m, const cv::Mat& frame) {
  for (int r = 0; r < m.rows; ++r) {
    const float* mr = m.ptr<float>(r);
    const float* pr = previous_.ptr<float>(r);
    float* br = best_.ptr<float>(r);
    float* bm = best_minus_.ptr<float>(r);
    float* bp = best_plus_.ptr<float>(r);
    int* bi = best_index_.ptr<int>(r);
    const Word* fr = frame.ptr<Word>(r);
    Word* sr = sharpest_.ptr<Word>(r);
    for (int c = 0; c < m.cols; ++c) {
      if (bi[c] == count_ - 1) bp[c] = mr[c];
      if (mr[c] > br[c]) {
        bm[c] = pr[c];
        br[c] = mr[c];
        bi[c] = count_;
        sr[c] = fr[c];
      }
    }
  }
}

Result<FocusStackResult> FocusStackAccumulator::finish() {
  if (finished_) return make_error("invalid_argument", "finish() called twice");
  if (count_ < 3)
    return make_error("too_few_samples",
                      "a focus stack needs at least 3 frames; got " + std::to_string(count_));
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
        delta = log_parabola_delta(std::max<double>(bm[c] - floor, eps), b[c] - floor,
                                   std::max<double>(bp[c] - floor, eps));
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
    rf.confidence = region_floor > 0 ? (*peak - region_floor) / region_floor
                                     : std::numeric_limits<double>::max();
    if (*peak - region_floor <= options_.min_peak_ratio * region_floor || *peak < 1.25 * least) {
      rf.status = kFocusFlat;
      rf.confidence = 0;
    } else if (i == 0 || i == count_ - 1) {
      rf.status = kFocusPeakAtEnd;
    } else {
      PeakFit pf = fit_symmetric_peak(rf.curve, region_floor, i);
      if (pf.samples < 3) pf = fit_log_parabola_peak(rf.curve, region_floor, i);
      pf.sigma = std::max(pf.sigma, kMinPeakSigma);
      rf.best_index = pf.index;
      rf.best_index_sigma = pf.sigma;
      rf.status = kFocusOk;
    }
    out.regions.push_back(std::move(rf));
  }
  return out;
}

}  // namespace camlab::analysis
