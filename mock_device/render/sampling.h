// Deterministic random numbers and stratified sample patterns for the renderer.
//
// Every pixel draws from its own counter-based stream (a hash of the seed, the frame and
// the pixel index), so a frame is the same whatever the number of threads or the order
// in which rows are rendered.
//
// Reentrant.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace camlab::mock {

// SplitMix64: a fast, well-mixed 64-bit generator (also a good hash of its state).
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  using result_type = uint64_t;
  static constexpr uint64_t min() { return 0; }
  static constexpr uint64_t max() { return ~0ull; }
  uint64_t operator()() { return next(); }

 private:
  uint64_t state_;
};

inline uint64_t mix_seed(uint64_t a, uint64_t b) {
  SplitMix64 g(a ^ (b * 0xD1B54A32D192ED03ull));
  return g.next();
}

// Below this CoC (px) the aperture is not sampled: a disk a tenth of a pixel wide changes
// a pixel-integrated edge by less than the rendering's own sampling noise.
inline constexpr double kNegligibleCocPx = 0.1;

// The automatic rule: lens grid k (k x k stratified samples) for a CoC of `coc_px`, the
// bigger the disk the more strata its edge needs to be resolved; docs/BENCHMARKS.md has the
// error-against-samples table it was chosen from. 0 (the pixel area alone) below
// kNegligibleCocPx.
inline int lens_grid_for_coc(double coc_px) {
  if (!(coc_px >= kNegligibleCocPx)) return 0;
  if (!(coc_px < 1e3)) return 16;
  return std::clamp(static_cast<int>(std::lround(4 + coc_px / 2.5)), 4, 16);
}

// Shirley and Chiu's concentric map from the square [0,1)^2 to the unit disk. It keeps
// strata compact and adjacent, which is why stratified lens samples converge as about
// n^-3/4 (docs/physics.md) instead of n^-1/2.
inline void concentric_disk(double u, double v, double* x, double* y) {
  const double a = 2 * u - 1, b = 2 * v - 1;
  if (a == 0 && b == 0) {
    *x = *y = 0;
    return;
  }
  double r, phi;
  if (a * a > b * b) {
    r = a;
    phi = (std::numbers::pi / 4) * (b / a);
  } else {
    r = b;
    phi = std::numbers::pi / 2 - (std::numbers::pi / 4) * (a / b);
  }
  *x = r * std::cos(phi);
  *y = r * std::sin(phi);
}

}  // namespace camlab::mock
