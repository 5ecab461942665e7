// The sensor's random numbers: counter-based uniforms and exact Poisson and Gaussian
// deviates, cheap enough to draw for every pixel of every frame.
//
// A deviate is a pure function of a key (the seed and frame number, hashed) and a
// counter (the pixel index and which draw of that pixel): no generator state runs from
// one pixel to the next, so a frame's noise is the same whatever the thread count or the
// order in which pixels are visited.
//
// - uniform: SplitMix64's output function on the Weyl sequence key + (counter + 1) x
//   golden ratio, i.e. SplitMix64 seeded with the key and advanced `counter` steps in one
//   jump; 53 random bits.
// - standard_normal: Marsaglia and Tsang's ziggurat (128 layers), with the layer, the
//   sign and the abscissa taken from separate bits of one hash (Doornik's remedy for the
//   original's correlation); 99% of draws cost one hash and one multiplication. The
//   tables are solved for at start-up, so the layers' areas are equal to double precision.
// - poisson: exact for every mean. Below kPoissonInversionMaxMean the CDF is inverted
//   from 0 with one uniform (about mean + 1 steps); at and above it Hormann's PTRS
//   (transformed rejection with squeeze, 1993), about 1.2 pairs of uniforms and no
//   logarithm for nine draws in ten.
//
// Thread-safe: pure functions of their arguments (the tables are built once, on first
// use, thread-safely).
#pragma once

#include <cstdint>

namespace camlab::mock::noise {

// Below this mean the Poisson CDF is inverted; at and above it PTRS, which Hormann
// validates for means of 10 and more.
inline constexpr double kPoissonInversionMaxMean = 10.0;

// Counters reserved per deviate: a Poisson draw takes up to 15 PTRS attempts of two
// uniforms, a normal draw up to 14 ziggurat draws; the last two counters of each are a
// Box-Muller fallback for the (below 1e-12) case that every attempt is rejected.
inline constexpr uint64_t kPoissonDraws = 32;
inline constexpr uint64_t kNormalDraws = 16;

// 64 random bits for (key, counter).
inline uint64_t hash(uint64_t key, uint64_t counter) {
  uint64_t z = key + (counter + 1) * 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Uniform in the open interval (0, 1): 53 bits, centred in their cell (never 0 or 1, so
// its logarithm is finite).
inline double uniform(uint64_t key, uint64_t counter) {
  return (static_cast<double>(hash(key, counter) >> 11) + 0.5) * 0x1.0p-53;
}

// Standard normal deviate number `index` of stream `key` (counters index x kNormalDraws
// onwards).
double standard_normal(uint64_t key, uint64_t index);

// The Poisson law of one mean (>= 0, finite; a negative or NaN mean is 0), with what its
// sampler needs computed once: the uniform parts of a frame (a chessboard's squares)
// give many pixels the same mean, and the sensor model keeps the law while it lasts.
class PoissonLaw {
 public:
  explicit PoissonLaw(double mean = 0);
  double mean() const { return mean_; }
  // Deviate number `index` of stream `key` (counters index x kPoissonDraws onwards).
  int64_t draw(uint64_t key, uint64_t index) const;

 private:
  int64_t by_inversion(uint64_t key, uint64_t first) const;
  int64_t by_ptrs(uint64_t key, uint64_t first) const;

  double mean_ = 0;
  bool ptrs_ = false;
  double exp_minus_mean_ = 1;  // inversion: P(0)
  // PTRS: the hat's parameters (Hormann's a, b, v_r, 1/alpha) and log(mean).
  double sqrt_mean_ = 0, a_ = 0, b_ = 0, v_r_ = 0, inv_alpha_ = 0, log_mean_ = 0;
};

// PoissonLaw(mean).draw(key, index).
int64_t poisson(double mean, uint64_t key, uint64_t index);

// log(k!) for k >= 0: a table below 64, Stirling's series above (error below 1e-15).
double log_factorial(int64_t k);

}  // namespace camlab::mock::noise
