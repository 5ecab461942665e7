#include "mock_device/render/noise_sampler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

namespace camlab::mock::noise {

namespace {

// The unnormalised normal density; the ziggurat only needs ratios of it.
double density(double x) { return std::exp(-0.5 * x * x); }

// The ziggurat: kLayers regions of equal area v under the density on x >= 0. Layer 0 is
// the rectangle [0, r] x [0, f(r)] plus the tail beyond r, drawn as one rectangle of
// width v / f(r); layer j >= 1 is [0, e(j-1)] x [f(e(j-1)), f(e(j))] with e(0) = r, each
// edge solved from the one below so the areas are equal, and e(kLayers - 1) = 0 (the
// peak). A uniform abscissa in a layer inside its inner edge is under the density and
// accepted at once; the rest (the wedges, the tail) are tested exactly.
constexpr int kLayers = 128;

struct Ziggurat {
  double r = 0;
  std::array<double, kLayers> outer{};        // the layer's width
  std::array<double, kLayers> inner_ratio{};  // its inner edge over its width
  std::array<double, kLayers> f_outer{};      // the density at its width (its bottom)
  std::array<double, kLayers> f_inner{};      // the density at its inner edge (its top)
};

double area_of_layers(double r) {
  return r * density(r) + std::sqrt(std::numbers::pi / 2) * std::erfc(r / std::numbers::sqrt2);
}

// How far the stack of layers built from `r` misses the peak: the top layer's area minus
// v, over its width; +1 when the layers reach the peak before the last one.
double closure(double r) {
  const double v = area_of_layers(r);
  double e = r;
  for (int j = 1; j < kLayers - 1; ++j) {
    const double y = density(e) + v / e;
    if (y >= 1) return 1;
    e = std::sqrt(-2 * std::log(y));
  }
  return density(e) + v / e - 1;
}

Ziggurat build_ziggurat() {
  // closure() falls through 0 once as r grows (r = 3.4426 for 128 layers): bisect it to
  // double precision rather than trust a printed constant.
  double lo = 3.0, hi = 4.0;
  for (int i = 0; i < 200 && lo < hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid == lo || mid == hi) break;
    (closure(mid) > 0 ? lo : hi) = mid;
  }
  Ziggurat z;
  z.r = hi;
  const double v = area_of_layers(z.r);
  std::array<double, kLayers> edge{};  // e(0) = r ... e(kLayers - 1) = 0
  edge[0] = z.r;
  for (int j = 1; j < kLayers - 1; ++j)
    edge[j] = std::sqrt(-2 * std::log(density(edge[j - 1]) + v / edge[j - 1]));
  edge[kLayers - 1] = 0;
  z.outer[0] = v / density(z.r);
  z.inner_ratio[0] = z.r / z.outer[0];
  z.f_outer[0] = z.f_inner[0] = density(z.r);
  for (int j = 1; j < kLayers; ++j) {
    z.outer[j] = edge[j - 1];
    z.inner_ratio[j] = edge[j] / edge[j - 1];
    z.f_outer[j] = density(edge[j - 1]);
    z.f_inner[j] = density(edge[j]);
  }
  return z;
}

const Ziggurat& ziggurat() {
  static const Ziggurat z = build_ziggurat();
  return z;
}

constexpr int kLogFactorialTable = 64;

const std::array<double, kLogFactorialTable>& log_factorial_table() {
  static const std::array<double, kLogFactorialTable> table = [] {
    std::array<double, kLogFactorialTable> t{};
    for (int k = 1; k < kLogFactorialTable; ++k) t[k] = t[k - 1] + std::log(static_cast<double>(k));
    return t;
  }();
  return table;
}

// Inversion walks the CDF from 0; means below 10 pass any uniform within a few dozen
// steps. The bound only stops a uniform that rounding left above the CDF's last value.
constexpr int kInversionSteps = 200;

const std::array<double, kInversionSteps + 1>& reciprocals() {
  static const std::array<double, kInversionSteps + 1> table = [] {
    std::array<double, kInversionSteps + 1> t{};
    for (int k = 1; k <= kInversionSteps; ++k) t[k] = 1.0 / k;
    return t;
  }();
  return table;
}

// floor() without the library call (x86-64's baseline has no rounding instruction).
// Beyond +-2^62 (a hat abscissa for a vanishing us, always rejected) it saturates.
double floor_of(double x) {
  if (!(x > -0x1p62 && x < 0x1p62)) return x < 0 ? -0x1p62 : 0x1p62;
  const double t = static_cast<double>(static_cast<int64_t>(x));
  return t > x ? t - 1 : t;
}

}  // namespace

double standard_normal(uint64_t key, uint64_t index) {
  const Ziggurat& z = ziggurat();
  const uint64_t first = index * kNormalDraws;
  const uint64_t last = first + kNormalDraws - 2;  // the fallback's two
  uint64_t c = first;
  while (c < last) {
    // One hash: 7 bits choose the layer, 1 the sign, the top 53 the abscissa.
    const uint64_t bits = hash(key, c++);
    const int layer = static_cast<int>(bits & (kLayers - 1));
    const double sign = (bits & kLayers) ? -1.0 : 1.0;
    const double u = static_cast<double>(static_cast<int64_t>(bits >> 11)) * 0x1.0p-53;  // [0, 1)
    const double x = u * z.outer[layer];
    if (u < z.inner_ratio[layer]) return sign * x;
    if (layer == 0) {
      // Beyond r: the tail, by Marsaglia's (1964) exponential rejection, repeated until
      // accepted (starting over with a new layer would thin the tail).
      while (c + 1 < last) {
        const double t = -std::log(uniform(key, c)) / z.r;
        const double s = -std::log(uniform(key, c + 1));
        c += 2;
        if (2 * s > t * t) return sign * (z.r + t);
      }
      break;
    }
    if (c >= last) break;
    // A wedge: under the density with the probability its height there gives.
    const double y = z.f_outer[layer] + uniform(key, c++) * (z.f_inner[layer] - z.f_outer[layer]);
    if (y < density(x)) return sign * x;
  }
  // Box-Muller on the last two counters: exact, and independent of the attempts.
  return std::sqrt(-2.0 * std::log(uniform(key, last))) *
         std::cos(2.0 * std::numbers::pi * uniform(key, last + 1));
}

PoissonLaw::PoissonLaw(double mean) : mean_(mean > 0 ? mean : 0) {
  ptrs_ = mean_ >= kPoissonInversionMaxMean;
  if (!ptrs_) {
    exp_minus_mean_ = std::exp(-mean_);
    return;
  }
  // PTRS (W. Hormann, "The transformed rejection method for generating Poisson random
  // variables", Insurance: Mathematics and Economics 12, 1993).
  hat_ = ptrs_hat(mean_);
}

int64_t PoissonLaw::draw(uint64_t key, uint64_t index) const {
  if (mean_ == 0) return 0;
  const uint64_t first = index * kPoissonDraws;
  return ptrs_ ? by_ptrs(key, first) : by_inversion(key, first);
}

// Inversion: walk the CDF from 0 until it passes one uniform.
int64_t PoissonLaw::by_inversion(uint64_t key, uint64_t first) const {
  const auto& inverse = reciprocals();
  const double u = uniform(key, first);
  double p = exp_minus_mean_;
  double cdf = p;
  int k = 0;
  while (u > cdf && k < kInversionSteps) {
    ++k;
    p *= mean_ * inverse[k];
    cdf += p;
  }
  return k;
}

namespace {

// PTRS: a hat from a transformed uniform, a squeeze that accepts most draws without a
// logarithm, and the exact test against log f(k) for the rest.
int64_t ptrs_draw(const PtrsHat& hat, double mean, uint64_t key, uint64_t first) {
  const uint64_t last = first + kPoissonDraws - 2;  // the fallback's two
  double log_mean = 0;                              // computed on the first exact test
  for (uint64_t c = first; c < last; c += 2) {
    const double u = uniform(key, c) - 0.5;
    const double v = uniform(key, c + 1);
    const double us = 0.5 - std::fabs(u);
    const double k = floor_of((hat.two_a / us + hat.b) * u + hat.shift);
    if (us >= 0.07 && v <= hat.v_r) return static_cast<int64_t>(k);  // the squeeze
    if (k < 0 || (us < 0.013 && v > us)) continue;
    if (log_mean == 0) log_mean = std::log(mean);  // mean >= 10: never 0 itself
    // log(v) + log(1 / alpha) - log(a / us^2 + b), as one logarithm.
    if (std::log(v * hat.inv_alpha / (hat.a / (us * us) + hat.b)) <=
        -mean + k * log_mean - log_factorial(static_cast<int64_t>(k)))
      return static_cast<int64_t>(k);
  }
  // Every attempt rejected: the normal approximation with continuity correction.
  const double z = std::sqrt(-2.0 * std::log(uniform(key, last))) *
                   std::cos(2.0 * std::numbers::pi * uniform(key, last + 1));
  return std::max<int64_t>(0, static_cast<int64_t>(std::floor(mean + hat.sqrt_mean * z + 0.5)));
}

}  // namespace

int64_t PoissonLaw::by_ptrs(uint64_t key, uint64_t first) const {
  return ptrs_draw(hat_, mean_, key, first);
}

int64_t poisson(double mean, uint64_t key, uint64_t index) {
  return PoissonLaw(mean).draw(key, index);
}

void poisson_row(const double* means, int64_t* out, int count, uint64_t key, uint64_t first_index,
                 std::vector<uint8_t>& scratch) {
  scratch.resize(static_cast<size_t>(count));
  uint8_t* pending = scratch.data();
  for (int i = 0; i < count; ++i) {
    // PoissonLaw's clamp of the mean, and its PTRS first attempt (by_ptrs, c = first).
    const double mean = means[i] > 0 ? means[i] : 0;
    const uint64_t first = (first_index + static_cast<uint64_t>(i)) * kPoissonDraws;
    const PtrsHat hat =
        ptrs_hat(mean >= kPoissonInversionMaxMean ? mean : kPoissonInversionMaxMean);
    const double u = uniform(key, first) - 0.5;
    const double v = uniform(key, first + 1);
    const double us = 0.5 - std::fabs(u);
    out[i] = static_cast<int64_t>(floor_of((hat.two_a / us + hat.b) * u + hat.shift));
    // Means below PTRS's range (inversion, or 0) go to the scalar law whatever the draw.
    // Written as the scalar squeeze's negation, so that a NaN anywhere falls to it too.
    pending[i] = !(mean >= kPoissonInversionMaxMean) | !((us >= 0.07) & (v <= hat.v_r));
  }
  // The rest: PTRS from its first attempt again (without rebuilding a law), or inversion.
  for (int i = 0; i < count; ++i) {
    if (!pending[i]) continue;
    const uint64_t index = first_index + static_cast<uint64_t>(i);
    out[i] = means[i] >= kPoissonInversionMaxMean
                 ? ptrs_draw(ptrs_hat(means[i]), means[i], key, index * kPoissonDraws)
                 : poisson(means[i], key, index);
  }
}

void standard_normal_row(double* out, int count, uint64_t key, uint64_t first_index,
                         std::vector<uint8_t>& scratch) {
  const Ziggurat& z = ziggurat();
  scratch.resize(static_cast<size_t>(count));
  uint8_t* pending = scratch.data();
  for (int i = 0; i < count; ++i) {
    // standard_normal's first ziggurat draw.
    const uint64_t bits = hash(key, (first_index + static_cast<uint64_t>(i)) * kNormalDraws);
    const int layer = static_cast<int>(bits & (kLayers - 1));
    const double sign = (bits & kLayers) ? -1.0 : 1.0;
    const double u = static_cast<double>(static_cast<int64_t>(bits >> 11)) * 0x1.0p-53;
    out[i] = sign * (u * z.outer[layer]);
    pending[i] = !(u < z.inner_ratio[layer]);
  }
  for (int i = 0; i < count; ++i)
    if (pending[i]) out[i] = standard_normal(key, first_index + static_cast<uint64_t>(i));
}

namespace {

// Stirling's series for log Gamma(x), x = k + 1 >= 65; the next term, 1/(1188 x^9), is
// below 1e-19.
double log_factorial_stirling(int64_t k) {
  const double x = static_cast<double>(k) + 1.0;
  const double x2 = x * x;
  return (x - 0.5) * std::log(x) - x + 0.5 * std::log(2 * std::numbers::pi) +
         (1.0 / 12 - (1.0 / 360 - (1.0 / 1260 - 1.0 / (1680 * x2)) / x2) / x2) / x;
}

// The series' own values up to the counts of large wells (128 KiB): PTRS's exact test
// needs log k! for k near the mean, and the series' two logarithms were a sixth of the
// sensor model's time.
constexpr int64_t kStirlingTable = 16384;

const std::vector<double>& stirling_table() {
  static const std::vector<double> table = [] {
    std::vector<double> t(static_cast<size_t>(kStirlingTable));
    for (int64_t k = kLogFactorialTable; k < kStirlingTable; ++k)
      t[static_cast<size_t>(k)] = log_factorial_stirling(k);
    return t;
  }();
  return table;
}

}  // namespace

double log_factorial(int64_t k) {
  if (k < kLogFactorialTable)
    return log_factorial_table()[static_cast<size_t>(std::max<int64_t>(k, 0))];
  if (k < kStirlingTable) return stirling_table()[static_cast<size_t>(k)];
  return log_factorial_stirling(k);
}

}  // namespace camlab::mock::noise
