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

#include <cmath>
#include <cstdint>
#include <vector>

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
  // Through int64_t: the 53 bits fit, and a signed conversion is one instruction where an
  // unsigned one branches on the top bit.
  return (static_cast<double>(static_cast<int64_t>(hash(key, counter) >> 11)) + 0.5) * 0x1.0p-53;
}

// Standard normal deviate number `index` of stream `key` (counters index x kNormalDraws
// onwards).
double standard_normal(uint64_t key, uint64_t index);

// PTRS's hat for one mean (>= kPoissonInversionMaxMean): Hormann's a, b, v_r and 1/alpha,
// with 2a and mean + 0.43 ready for the first step. One function for the law and the
// row sampler, so both draw the same deviates to the bit.
struct PtrsHat {
  double sqrt_mean = 0, a = 0, b = 0, v_r = 0, inv_alpha = 0, two_a = 0, shift = 0;
};

inline PtrsHat ptrs_hat(double mean) {
  PtrsHat hat;
  hat.sqrt_mean = std::sqrt(mean);
  hat.b = 0.931 + 2.53 * hat.sqrt_mean;
  hat.a = -0.059 + 0.02483 * hat.b;
  // v_r = 0.9277 - 3.6224 / (b - 2) and 1/alpha = 1.1239 + 1.1328 / (b - 3.4), with one
  // division for the two (b >= 8.9 here, so neither denominator is near 0).
  const double below_2 = hat.b - 2, below_3_4 = hat.b - 3.4;
  const double inverse_product = 1.0 / (below_2 * below_3_4);
  hat.v_r = 0.9277 - 3.6224 * below_3_4 * inverse_product;
  hat.inv_alpha = 1.1239 + 1.1328 * below_2 * inverse_product;
  hat.two_a = 2 * hat.a;
  hat.shift = mean + 0.43;
  return hat;
}

// The Poisson law of one mean (>= 0, finite; a negative or NaN mean is 0), with what its
// sampler needs computed once.
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
  // log(mean) is left to the draws that reach the exact test (about one in five): under a
  // lens's falloff every pixel has its own mean, so a law is built for each pixel.
  PtrsHat hat_;
};

// PoissonLaw(mean).draw(key, index).
int64_t poisson(double mean, uint64_t key, uint64_t index);

// A row of deviates at once: out[i] = poisson(means[i], key, first_index + i) and
// normal_out[i] = standard_normal(key, first_index + i), the same numbers to the bit.
// Every deviate's first attempt is taken for the whole row in one branch-free pass (the
// PTRS squeeze accepts about three in four, the ziggurat's rectangles 99%), and only the
// rest go through the scalar samplers: a frame's pixels each have their own mean, and a
// pixel at a time the samplers wait on their own divisions and mispredicted branches.
// `scratch` holds a row's flags; reused across rows to keep the pass allocation-free.
void poisson_row(const double* means, int64_t* out, int count, uint64_t key, uint64_t first_index,
                 std::vector<uint8_t>& scratch);
void standard_normal_row(double* out, int count, uint64_t key, uint64_t first_index,
                         std::vector<uint8_t>& scratch);

// log(k!) for k >= 0: a table below 64, Stirling's series above (error below 1e-15),
// tabulated below 16384.
double log_factorial(int64_t k);

}  // namespace camlab::mock::noise
